"""Episode videos: MP4 through imageio's FFMPEG plugin (the declared imageio-ffmpeg), read back."""

from __future__ import annotations

import numpy as np
import pytest

from spark_bench.errors import InputError
from spark_bench.rl.rollout import write_video


def frames(n: int = 12, size: int = 64, height: int | None = None) -> list[np.ndarray]:
    """A white square moving left to right on black: each frame different, known content."""
    out = []
    for k in range(n):
        frame = np.zeros((height or size, size, 3), np.uint8)
        x = 4 + 4 * k
        frame[24:40, x:x + 16] = 255
        out.append(frame)
    return out


def test_mp4_is_written_and_reads_back_with_the_moving_square(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    path = write_video(frames(), tmp_path / "episode.mp4", fps=10)
    back = iio.imread(path, plugin="FFMPEG")
    assert back.shape[0] == 12 and back.shape[1:3] == (64, 64)
    # lossy codec: the square is where it was drawn, give or take compression
    for k in (0, 11):
        column_brightness = back[k, 24:40].mean(axis=(0, 2))
        assert abs(int(np.argmax(column_brightness > 128)) - (4 + 4 * k)) <= 2


def test_mp4_of_odd_size_is_padded_not_resampled(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    path = write_video(frames(height=56), tmp_path / "episode.mp4", fps=10)
    back = iio.imread(path, plugin="FFMPEG")
    assert back.shape[1:3] == (64, 64)  # 56 rows padded to 64, columns untouched
    column_brightness = back[5, 24:40].mean(axis=(0, 2))
    assert abs(int(np.argmax(column_brightness > 128)) - (4 + 4 * 5)) <= 2


def test_unknown_video_suffix_is_refused(tmp_path):
    with pytest.raises(InputError, match="video must end in"):
        write_video(frames(2), tmp_path / "episode.avi", fps=10)
