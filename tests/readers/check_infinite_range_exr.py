"""Reads range EXRs of a frame that hits nothing with OpenEXR, the reference library, and
checks that they are RLE files whose range channel is +inf in every pixel, bit for bit.

Usage: python3 tests/readers/check_infinite_range_exr.py CHANNEL [PATH WIDTH HEIGHT]...
"""

import sys

import numpy as np
import OpenEXR

INFINITY_BITS = 0x7F800000


def main():
    channel, files = sys.argv[1], sys.argv[2:]
    if not files or len(files) % 3:
        sys.exit(__doc__)
    for path, width, height in zip(files[0::3], files[1::3], files[2::3]):
        exr = OpenEXR.File(path, separate_channels=True)
        compression = str(exr.header()["compression"])
        assert "RLE" in compression, f"{path}: {compression}"
        pixels = exr.channels()[channel].pixels
        assert pixels.shape == (int(height), int(width)) and pixels.dtype == np.float32, (
            path,
            pixels.shape,
            pixels.dtype,
        )
        bits = pixels.view(np.uint32)
        assert (bits == INFINITY_BITS).all(), f"{path}: {np.count_nonzero(bits != INFINITY_BITS)} values are not +inf"
        print(path, "ok")


if __name__ == "__main__":
    main()
