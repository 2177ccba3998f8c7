"""The ``window`` projector under Xvfb: each pattern is on the X screen pixel for pixel."""
import numpy as np
import pytest
from devices_xvfb import SCREEN, screenshot

from fringe3d.patterns import render_set, sets


@pytest.fixture(scope="module")
def projector(xvfb):
    from fringe3d.devices import open_projector
    from fringe3d.utils.warning_types import DeviceWarning
    with pytest.warns(DeviceWarning, match="reports no refresh rate"):  # Xvfb has no video timing
        p = open_projector("window:0")
    yield p
    p.close()


def test_window_projector_fills_the_screen_at_its_native_size(projector):
    assert (projector.width, projector.height) == SCREEN
    assert projector.describe()["screen"] == 0


def test_screenshot_of_each_sinusoid_equals_the_pattern_exactly(projector, xvfb):
    ps = sets.phase_shift(18, 3, "v", width=SCREEN[0], height=SCREEN[1]).concat(
        sets.phase_shift(21, 3, "h", width=SCREEN[0], height=SCREEN[1]))
    worst = 0
    for img in render_set(ps):
        projector.show(img)
        shot = screenshot(xvfb).astype(int)
        worst = max(worst, int(np.abs(shot - img[..., None]).max()))
    print(f"window projector under Xvfb: max |screenshot - pattern| = {worst} over {len(ps)} frames")
    assert worst == 0


def test_rgb_frame_keeps_every_channel_exact(projector, xvfb):
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (SCREEN[1], SCREEN[0], 3), dtype=np.uint8)
    projector.show(img)
    assert np.array_equal(screenshot(xvfb), img)


def test_smaller_image_is_shown_top_left_on_black(projector, xvfb):
    img = np.full((50, 70), 200, np.uint8)
    projector.show(img)
    shot = screenshot(xvfb)[..., 0]
    assert np.all(shot[:50, :70] == 200) and shot[50:].max() == 0 and shot[:, 70:].max() == 0


def test_image_larger_than_the_screen_is_refused(projector):
    with pytest.raises(ValueError,
                       match=r"the image is 300x200 pixels but the window projector \(screen 0\) is 256x200"):
        projector.show(np.zeros((200, 300), np.uint8))


def test_screen_index_that_does_not_exist_lists_the_screens(xvfb):
    from fringe3d.devices import open_projector
    with pytest.raises(ValueError,
                       match=r"screen 3 does not exist; this display has 1 screen\(s\): 0: 256x200 at \(0,0\)"):
        open_projector("window:3")
