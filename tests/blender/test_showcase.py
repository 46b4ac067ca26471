"""sample_scenes/showcase.py without its (minute-long) build: the beats' schedule, and the
clip's MP4 through Blender's own video output (the sequencer to FFmpeg) on both versions.
The build itself runs in the demo (``bash tools/demo.sh --quick`` renders every beat)."""

import bpy
import numpy as np
import pytest

from sample_scenes import showcase


def test_beats_are_held_then_blended_in_order():
    beats = showcase.beat_frames()
    assert [b[0] for b in beats] == ["Neutral", "Surprise", "Anger", "Surprise + Anger", "Smile", "Sadness"]
    for (_n, first, last), (_m, nxt, _l) in zip(beats, beats[1:]):
        assert last - first == showcase.HOLD and nxt - last == showcase.BLEND
    for name, first, last in beats:
        assert first < showcase.still_frame(name) < last
    assert showcase.BEATS[3][1] == {**showcase.SURPRISE, **showcase.ANGER}


def test_views_frame_the_eye_corner_and_the_glabella():
    lm = {"eye_L": np.array([0.032, -0.09, 0.035]), "glabella": np.array([0.0, -0.107, 0.057])}
    v = showcase.views(lm)
    assert tuple(v) == showcase.VIEWS and v["front"] is None
    corner, height, _d = v["eye_corner"]
    assert corner[0] > lm["eye_L"][0] and 0.02 < height < 0.08
    assert abs(v["glabella"][0][0]) < 1e-9


@pytest.mark.render
def test_encode_mp4_with_blenders_video_output(tmp_path):
    frames = []
    for k in range(6):
        img = bpy.data.images.new(f"f{k}", 64, 48)
        px = np.zeros((48, 64, 4), np.float32)
        px[..., 0] = k / 5.0
        px[..., 3] = 1.0
        img.pixels.foreach_set(px.ravel())
        img.filepath_raw = str(tmp_path / f"frame_{k + 1:04d}.png")
        img.file_format = "PNG"
        img.save()
        frames.append(tmp_path / f"frame_{k + 1:04d}.png")
    scenes = len(bpy.data.scenes)
    mp4 = showcase.encode_mp4(frames, tmp_path / "clip.mp4", fps=12)
    data = mp4.read_bytes()
    assert mp4.name == "clip.mp4" and len(data) > 500 and data[4:8] == b"ftyp"
    assert len(bpy.data.scenes) == scenes  # its scene is removed again
