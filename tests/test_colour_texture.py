"""A colour camera's capture keeps its colour: the frames are decoded grey (BT.601 luma), the PLY
gets ``texture * chroma`` with the frames' own chroma (:mod:`fringe3d.io.colour_texture`)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

import fringe3d
from fringe3d.io.capture import list_frame_files
from fringe3d.io.colour_texture import LUMA

#: Chroma of the left and right halves of the image, each with luma 1 (their grey is the frame).
LEFT = np.array([1.2, 0.9, 0.8]) / (LUMA @ [1.2, 0.9, 0.8])
RIGHT = np.array([0.8, 1.0, 1.3]) / (LUMA @ [0.8, 1.0, 1.3])


@pytest.fixture(scope="module")
def colour_capture(tmp_path_factory):
    """The tiny preset's capture with every frame rewritten as an RGB PNG of the same luma (two tints)."""
    folder = tmp_path_factory.mktemp("colour") / "cap"
    fringe3d.simulate_capture(folder, preset="tiny", seed=0, progress=False)
    for path in list_frame_files(folder):
        grey = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).astype(np.float64)
        w = grey.shape[1]
        chroma = np.where(np.arange(w)[None, :, None] < w // 2, LEFT, RIGHT)
        rgb = np.clip(np.round(grey[..., None] * chroma), 0, np.iinfo(np.uint8).max).astype(np.uint8)
        cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    return folder


def test_colour_frames_give_the_ply_the_cameras_colours(colour_capture, tmp_path):
    o3d = pytest.importorskip("open3d")
    rec = fringe3d.reconstruct_capture(colour_capture, colour_capture / "rig.json")
    assert rec.texture_rgb is not None and rec.texture_rgb.shape == (*rec.texture.shape, 3)
    np.testing.assert_allclose(rec.texture_rgb @ LUMA, rec.texture, atol=0.02)  # luma is the grey texture
    cloud = o3d.t.io.read_point_cloud(str(rec.save_ply(tmp_path / "p.ply")))
    colours = cloud.point.colors.numpy().astype(float)  # uint8 red, green, blue
    cols = np.nonzero(rec.mask)[1]
    bright = colours.min(axis=1) > 40  # away from the dark background and 8-bit rounding
    for half, chroma in ((cols < rec.mask.shape[1] // 2, LEFT), (cols >= rec.mask.shape[1] // 2, RIGHT)):
        sel = half & bright & (colours.max(axis=1) < 250)  # unclipped
        assert sel.sum() > 100
        ratio = np.median(colours[sel] / colours[sel, 1:2], axis=0)  # red / green, 1, blue / green
        np.testing.assert_allclose(ratio, chroma / chroma[1], rtol=0.03)


def test_grey_frames_keep_a_grey_texture(tmp_path):
    from fringe3d.io.colour_texture import capture_chroma

    folder = tmp_path / "cap"
    fringe3d.simulate_capture(folder, preset="tiny", seed=0, progress=False)
    assert capture_chroma(folder, 4) is None
