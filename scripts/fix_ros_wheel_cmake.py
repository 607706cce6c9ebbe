"""Point the ROS wheels' exported CMake files at this venv's Python and numpy headers.

The PyPI ROS 2 wheels were built in a manylinux image; their `*__rosidl_generator_pyExport.cmake`
files name that image's include dirs (/opt/python/cp311-cp311/...), so colcon cannot generate our
interfaces until the paths name this interpreter's include dir and numpy's. Idempotent.
"""

import pathlib
import re
import sys
import sysconfig

import numpy

BUILDER_PYTHON_INCLUDE = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
BUILDER_NUMPY_INCLUDE = re.compile(
    r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/_core/include")


def main() -> int:
    prefix = pathlib.Path(sys.prefix)
    python_include = sysconfig.get_paths()["include"]
    numpy_include = numpy.get_include()
    fixed = 0
    for path in (prefix / "share").glob("*/cmake/*__rosidl_generator_pyExport.cmake"):
        text = path.read_text()
        new = BUILDER_NUMPY_INCLUDE.sub(numpy_include, text)
        new = BUILDER_PYTHON_INCLUDE.sub(python_include, new)
        if new != text:
            path.write_text(new)
            fixed += 1
    print(f"fix_ros_wheel_cmake: rewrote {fixed} CMake export file(s) under {prefix / 'share'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
