"""numpy <-> sensor_msgs/Image and time conversions, with validation that says what is wrong.

No rclpy import: bag tools and tests use these too.
"""

import numpy as np
from builtin_interfaces.msg import Time
from sensor_msgs.msg import Image

# encoding -> (numpy dtype, channels)
ENCODINGS = {
    "rgb8": (np.uint8, 3),
    "bgr8": (np.uint8, 3),
    "rgba8": (np.uint8, 4),
    "bgra8": (np.uint8, 4),
    "mono8": (np.uint8, 1),
    "16UC1": (np.uint16, 1),
    "mono16": (np.uint16, 1),
    "32FC1": (np.float32, 1),
}


class ImageFormatError(ValueError):
    """An Image message that cannot be read as the array it claims to be."""


def image_to_numpy(msg: Image, expected_encodings=None) -> np.ndarray:
    """Image -> array (H, W) or (H, W, C); raises ImageFormatError with the reason."""
    if expected_encodings is not None and msg.encoding not in expected_encodings:
        raise ImageFormatError(
            f"encoding '{msg.encoding}' not accepted (expected one of {sorted(expected_encodings)})")
    if msg.encoding not in ENCODINGS:
        raise ImageFormatError(f"unsupported encoding '{msg.encoding}'")
    dtype, channels = ENCODINGS[msg.encoding]
    itemsize = np.dtype(dtype).itemsize
    row_bytes = msg.width * channels * itemsize
    if msg.height == 0 or msg.width == 0:
        raise ImageFormatError("empty image (0 x 0)")
    if msg.step < row_bytes:
        raise ImageFormatError(f"step {msg.step} < width * pixel size {row_bytes}")
    data = np.frombuffer(bytes(msg.data) if not isinstance(msg.data, (bytes, bytearray, memoryview))
                         else msg.data, dtype=np.uint8)
    if data.size != msg.step * msg.height:
        raise ImageFormatError(
            f"data has {data.size} bytes, expected step * height = {msg.step * msg.height}")
    rows = data.reshape(msg.height, msg.step)[:, :row_bytes]
    array = np.ascontiguousarray(rows).view(dtype)
    big_endian_host = np.dtype(dtype).byteorder == ">" or (
        np.dtype(dtype).byteorder == "=" and np.little_endian is False)
    if itemsize > 1 and bool(msg.is_bigendian) != big_endian_host:
        array = array.byteswap()
    shape = (msg.height, msg.width) if channels == 1 else (msg.height, msg.width, channels)
    return array.reshape(shape)


# Colour encodings read as RGB (image_to_rgb): realsense-ros publishes rgb8, OpenCV-based drivers bgr8,
# ZED and many USB cameras bgra8 / rgba8. encoding -> the channels, in R, G, B order, of its pixels.
RGB_ENCODINGS = {"rgb8": slice(None), "bgr8": slice(None, None, -1), "rgba8": slice(0, 3),
                 "bgra8": slice(2, None, -1)}


def image_to_rgb(msg: Image, accepted=tuple(RGB_ENCODINGS)) -> np.ndarray:
    """Colour Image -> (H, W, 3) uint8 RGB: blue-first encodings reordered, alpha dropped. Any other
    encoding raises ImageFormatError naming the accepted ones."""
    unknown = [encoding for encoding in accepted if encoding not in RGB_ENCODINGS]
    if unknown:
        raise ValueError(f"image_to_rgb cannot read {unknown} (it reads {list(RGB_ENCODINGS)})")
    array = image_to_numpy(msg, accepted)
    return np.ascontiguousarray(array[..., RGB_ENCODINGS[msg.encoding]])


def numpy_to_image(array: np.ndarray, encoding: str, header=None) -> Image:
    """Array -> Image with the given encoding; the dtype and channels must match it."""
    if encoding not in ENCODINGS:
        raise ImageFormatError(f"unsupported encoding '{encoding}'")
    dtype, channels = ENCODINGS[encoding]
    array = np.ascontiguousarray(array, dtype=dtype)
    if (channels == 1 and array.ndim != 2) or (channels > 1 and array.shape[2:] != (channels,)):
        raise ImageFormatError(f"array of shape {array.shape} does not fit encoding '{encoding}'")
    msg = Image()
    if header is not None:
        msg.header = header
    msg.height, msg.width = int(array.shape[0]), int(array.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = int(array.shape[1] * channels * np.dtype(dtype).itemsize)
    msg.data = array.tobytes()
    return msg


def time_to_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_time(ns: int) -> Time:
    return Time(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def grid_from_heightmap(msg):
    """The grid.HeightmapGrid an impurity_interfaces/Heightmap message lies on: its resolution and
    origin, its size from the height image. ImageFormatError when they cannot describe a grid
    (resolution not a positive finite number, an empty image)."""
    from impurity_common.grid import HeightmapGrid

    origin = msg.origin
    try:
        return HeightmapGrid.from_origin(float(msg.resolution), float(origin.x), float(origin.y),
                                         float(origin.z), int(msg.height.height), int(msg.height.width))
    except ValueError as error:
        raise ImageFormatError(str(error)) from error
