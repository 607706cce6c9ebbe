"""Image <-> numpy conversions: colour encodings real cameras publish, layout checks."""

import numpy as np
import pytest
from sensor_msgs.msg import Image

from impurity_common.conversions import (
    RGB_ENCODINGS,
    ImageFormatError,
    image_to_numpy,
    image_to_rgb,
    numpy_to_image,
)

RGB = np.random.default_rng(0).integers(0, 256, (4, 5, 3), dtype=np.uint8)
ALPHA = np.random.default_rng(1).integers(0, 256, (4, 5, 1), dtype=np.uint8)


def as_encoding(rgb: np.ndarray, encoding: str) -> np.ndarray:
    """The pixel bytes a camera publishing `encoding` sends for this RGB image."""
    bgr = rgb[..., ::-1]
    return {"rgb8": rgb, "bgr8": bgr, "rgba8": np.concatenate([rgb, ALPHA], axis=2),
            "bgra8": np.concatenate([bgr, ALPHA], axis=2)}[encoding]


@pytest.mark.parametrize("encoding", ["rgb8", "bgr8", "rgba8", "bgra8"])
def test_colour_encodings_are_read_as_rgb(encoding):
    msg = numpy_to_image(as_encoding(RGB, encoding), encoding)
    rgb = image_to_rgb(msg)
    assert rgb.shape == (4, 5, 3) and rgb.dtype == np.uint8 and rgb.flags.c_contiguous
    assert np.array_equal(rgb, RGB)


@pytest.mark.parametrize("encoding", ["rgba8", "bgra8"])
def test_four_channel_images_round_trip_and_respect_row_padding(encoding):
    pixels = as_encoding(RGB, encoding)
    msg = numpy_to_image(pixels, encoding)
    assert msg.step == 5 * 4 and np.array_equal(image_to_numpy(msg), pixels)
    padded = Image(height=4, width=5, encoding=encoding, step=5 * 4 + 12)  # rows padded to 32 bytes
    rows = np.zeros((4, padded.step), np.uint8)
    rows[:, :20] = pixels.reshape(4, 20)
    padded.data = rows.tobytes()
    assert np.array_equal(image_to_rgb(padded), RGB)


@pytest.mark.parametrize("encoding", ["mono8", "16UC1", "yuv422", "8UC3"])
def test_other_encodings_are_refused_with_the_accepted_list(encoding):
    msg = Image(height=1, width=1, encoding=encoding, step=3, data=bytes(3))
    with pytest.raises(ImageFormatError) as error:
        image_to_rgb(msg)
    assert f"encoding '{encoding}' not accepted" in str(error.value)
    for accepted in RGB_ENCODINGS:
        assert accepted in str(error.value)


def test_a_narrower_accepted_list_is_honoured_and_an_unreadable_one_refused():
    msg = numpy_to_image(as_encoding(RGB, "bgra8"), "bgra8")
    with pytest.raises(ImageFormatError, match=r"expected one of \['rgb8'\]"):
        image_to_rgb(msg, ("rgb8",))
    with pytest.raises(ValueError, match="mono8"):
        image_to_rgb(msg, ("rgb8", "mono8"))


def test_short_data_and_a_step_below_the_row_are_refused():
    msg = numpy_to_image(as_encoding(RGB, "rgba8"), "rgba8")
    short = Image(height=msg.height, width=msg.width, encoding="rgba8", step=msg.step,
                  data=bytes(msg.data)[:-1])
    with pytest.raises(ImageFormatError, match="bytes"):
        image_to_rgb(short)
    narrow = Image(height=msg.height, width=msg.width, encoding="rgba8", step=15, data=bytes(msg.data))
    with pytest.raises(ImageFormatError, match="step"):
        image_to_rgb(narrow)
    with pytest.raises(ImageFormatError, match="does not fit"):
        numpy_to_image(RGB, "rgba8")
