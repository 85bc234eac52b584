"""The viewer in a real headless browser (Debian's chromium driven by Playwright).

Skipped where chromium or Playwright is missing, except under CI (the CI variable set), where a
missing browser is a failure: `.ci/run` installs it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from urllib.parse import urlparse

import numpy as np
import pytest
from conftest import get_model, landing_run, viewer_servers

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
FLAGS = [
    "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
    "--no-first-run", "--disable-background-networking", "--disable-component-update",
    "--disable-sync",
]  # fmt: skip


def _require_browser():
    missing = []
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        missing.append("playwright")
    if not os.path.exists(CHROMIUM):
        missing.append("chromium")
    if missing:
        if os.environ.get("CI"):
            pytest.fail(f"browser tests need {', '.join(missing)} (CI must install them)")
        pytest.skip(f"no {', '.join(missing)} on this machine")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    _require_browser()
    from playwright.sync_api import sync_playwright

    profile = str(tmp_path_factory.mktemp("profile"))
    with sync_playwright() as p:
        ctx = p.chromium.launch_persistent_context(
            profile,
            executable_path=CHROMIUM,
            headless=True,
            args=FLAGS,
            viewport={"width": 640, "height": 480},
        )
        yield ctx
        ctx.close()
    ps = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True).stdout
    assert profile not in ps, "a browser process outlived the tests"


@pytest.fixture(scope="module")
def landing():
    return landing_run(0.6)


class Page:
    """A page with its console errors and requests recorded."""

    def __init__(self, context, url: str) -> None:
        self.page = context.new_page()
        self.errors, self.requests = [], []
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("request", lambda r: self.requests.append(r.url))
        # the browser asks every server for a favicon; meshcat has none (a 404 is no error of ours)
        self.page.route("**/favicon.ico", lambda route: route.fulfill(status=204, body=""))
        self.page.goto(url)
        self.page.wait_for_function(
            "() => window.viewer && viewer.scene_tree.find(['meshcat','humanoid','body'])"
            ".object.children.length > 5",
            timeout=60_000,
        )
        time.sleep(1.0)  # a few rendered frames

    def shot(self) -> np.ndarray:
        from io import BytesIO

        from PIL import Image

        return np.asarray(Image.open(BytesIO(self.page.screenshot())).convert("RGB"), dtype=int)

    def command(self, path: str, prop: str, value) -> None:
        js = (
            "([p, k, v]) => viewer.handle_command("
            "{type: 'set_property', path: p, property: k, value: v})"
        )
        self.page.evaluate(js, [path, prop, value])
        time.sleep(0.5)

    def seek(self, t: float) -> None:
        self.page.evaluate(
            "(t) => { viewer.animator.pause(); viewer.animator.seek(t); viewer.set_dirty(); }", t
        )
        time.sleep(0.5)

    def screen_position(self, path: list[str]) -> np.ndarray:
        js = """(path) => {
            const o = viewer.scene_tree.find(path).object;
            const v = o.position.clone(); o.getWorldPosition(v); v.project(viewer.camera);
            return [v.x, v.y];
        }"""
        return np.array(self.page.evaluate(js, path))

    def visible(self, path: list[str]) -> bool:
        return self.page.evaluate("(p) => viewer.scene_tree.find(p).object.visible", path)

    def close(self) -> None:
        self.page.close()


def _local_only(requests, allowed_scheme):
    bad = []
    for url in requests:
        u = urlparse(url)
        if u.scheme in ("data", "blob"):
            continue
        if u.scheme == allowed_scheme == "file":
            continue
        if u.scheme in ("http", "https", "ws") and u.hostname == "127.0.0.1":
            continue
        bad.append(url)
    return bad


def _changed_pixels(a: np.ndarray, b: np.ndarray) -> int:
    return int((np.abs(a - b).sum(axis=2) > 30).sum())


def test_html_export_in_the_browser(browser, landing, tmp_path):
    h = get_model("male", "quaternion")
    from humanoid.viewer import export_html

    path = export_html(h, tmp_path / "landing.html", traj=landing)
    page = Page(browser, path.as_uri())
    try:
        page.seek(0.0)
        shown = page.shot()
        page.command("/meshcat/humanoid/body", "visible", False)
        hidden = page.shot()
        assert _changed_pixels(shown, hidden) > 2000, "the body is not visibly drawn"
        page.command("/meshcat/humanoid/body", "visible", True)
        # the animation moves: the left foot moves on screen during the fall (the camera
        # fixed: it would follow the body otherwise)
        page.page.uncheck("#follow")
        foot = ["meshcat", "humanoid", "body", "left_foot_0"]
        page.seek(0.0)
        before = page.screen_position(foot)
        page.seek(0.5)
        after = page.screen_position(foot)
        assert np.abs(after - before).max() > 0.005, (before, after)
        # force arrows: hidden in the air, shown in stance
        arrow = ["meshcat", "humanoid", "forces", "left"]
        page.seek(0.02)
        assert not page.visible(arrow)
        page.seek(0.45)
        assert page.visible(arrow)
        assert not page.errors, page.errors
        assert not _local_only(page.requests, "file"), page.requests
    finally:
        page.close()


def test_live_viewer_in_the_browser(browser):
    from humanoid.viewer import LiveViewer, SceneView

    h = get_model("male", "quaternion")
    with LiveViewer() as live:
        view = SceneView(live.vis, h)
        view.show(h.standing_configuration())
        page = Page(browser, live.url)
        try:
            shown = page.shot()
            live.vis["humanoid/body"].set_property("visible", False)
            time.sleep(1.0)
            hidden = page.shot()
            assert _changed_pixels(shown, hidden) > 2000
            assert not page.errors, page.errors
            assert not _local_only(page.requests, "http"), page.requests
        finally:
            page.close()
        server = live.proc.pid
    assert live.proc.poll() is not None
    assert (
        not os.path.exists(f"/proc/{server}") or "zombie" in open(f"/proc/{server}/status").read()
    )


def test_no_viewer_process_is_left():
    servers = viewer_servers()
    assert not servers, servers


@pytest.mark.parametrize("where", ["html", "live"])
def test_player_follows_the_body(browser, tmp_path, where):
    """The page's own player, in the HTML file and on the live server: pause, a time slider,
    the simulated time, a legend, and a camera that follows the body (a body carried 2 m along x
    in 2 s stays in the middle of the view)."""
    import contextlib

    from humanoid.simulation import Trajectory
    from humanoid.viewer import LiveViewer, SceneView, export_html

    h = get_model("male", "quaternion")
    t = np.linspace(0.0, 2.0, 21)
    q = np.tile(h.standing_configuration(), (len(t), 1))
    q[:, 0] += t  # 1 m/s forward
    zeros = np.zeros((len(t), h.nv))
    traj = Trajectory(t, q, zeros, zeros.copy(), {}, np.zeros(len(t)), np.zeros(len(t)), {})
    with contextlib.ExitStack() as stack:
        if where == "html":
            url = export_html(h, tmp_path / "carried.html", traj=traj, title="carried").as_uri()
        else:
            live = stack.enter_context(LiveViewer())
            view = SceneView(live.vis, h)
            view.animate(traj)
            url = live.publish(view, "carried")
            assert url.startswith("http://127.0.0.1:") and url.endswith("/humanoid/")
        _check_player(Page(browser, url), "file" if where == "html" else "http")


def _check_player(page: Page, scheme: str) -> None:
    com = ["meshcat", "humanoid", "com"]

    def slide_to(value: float) -> str:
        page.page.evaluate(
            "(v) => { const s = document.getElementById('slider'); s.value = v;"
            " s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change')); }",
            value,
        )
        time.sleep(0.5)
        return page.page.inner_text("#time")

    try:
        legend = page.page.inner_text("#legend")  # the overlays drawn, and only those
        assert "centre of mass" in legend and "contact forces" not in legend  # (none carried)
        assert page.page.evaluate("viewer.animator.playing")  # it plays on load, in a loop
        page.page.click("#play")  # the button pauses
        time.sleep(0.3)
        assert not page.page.evaluate("viewer.animator.playing")
        assert page.page.inner_text("#play") == "play"
        assert slide_to(0.5) == "t = 0.50 s"
        at_half = page.screen_position(com)
        assert slide_to(1.5) == "t = 1.50 s"
        at_one_half = page.screen_position(com)
        assert np.abs(at_one_half - at_half).max() < 0.02, (at_half, at_one_half)
        page.page.uncheck("#follow")
        slide_to(0.5)
        still = page.screen_position(com)
        slide_to(1.5)
        moved = page.screen_position(com)
        assert np.abs(moved - still).max() > 0.1, (still, moved)  # without follow it leaves
        assert not page.errors, page.errors
        assert not _local_only(page.requests, scheme), page.requests
    finally:
        page.close()


@pytest.mark.parametrize("where", ["html", "live"])
def test_camera_presets_and_the_recording(browser, tmp_path, where):
    """A 6 m walk with its markers, opened in the side view: the camera stands where the side
    preset says (in three.js's axes) and follows the body: the body's height (feet to head on
    screen) stays over half the view at the start and the end; the buttons and keys switch to
    front and top (top: both ends of the walk in view); a marker missing in a frame is hidden
    there, and shown where the file has it."""
    import contextlib
    import warnings

    from test_viewer import _carried, _recording

    from humanoid.viewer import HiddenMarkerWarning, LiveViewer, SceneView, export_html

    h = get_model("male", "quaternion")
    traj = _carried(h, 6.0, 4.0, 41)
    measured, marker_set, _ = _recording(h, traj)
    with contextlib.ExitStack() as stack:
        stack.enter_context(warnings.catch_warnings())
        warnings.simplefilter("ignore", HiddenMarkerWarning)
        if where == "html":
            path = export_html(h, tmp_path / "walk.html", traj=traj, camera="side",
                               markers=measured, marker_set=marker_set)  # fmt: skip
            url = path.as_uri()
        else:
            live = stack.enter_context(LiveViewer())
            view = SceneView(live.vis, h, camera="side")
            view.set_markers(measured, marker_set)
            view.animate(traj)
            url = live.publish(view, "walk")
        page = Page(browser, url)
        try:
            _check_presets(page, traj, measured)
            assert not page.errors, page.errors
        finally:
            page.close()


def _check_presets(page: Page, traj, measured) -> None:
    import json
    import re

    html = page.page.content()
    cameras = json.loads(re.search(r"var cameras = (\{.*?\}\}), origin", html).group(1))
    head, foot = ["meshcat", "humanoid", "body", "head_1"], ["meshcat", "humanoid", "body",
                                                             "left_foot_0"]  # fmt: skip
    camera = "() => { const v = new MeshCat.THREE.Vector3(); viewer.camera.getWorldPosition(v);"
    camera += " return [v.x, v.y, v.z]; }"
    page.seek(0.0)
    time.sleep(0.5)
    assert page.page.evaluate("humanoidPlayer.view()") == "side"
    assert np.allclose(page.page.evaluate(camera), cameras["side"]["eye"], atol=0.02)
    for t in (0.0, 3.9):
        page.seek(t)
        span = abs(page.screen_position(head)[1] - page.screen_position(foot)[1]) / 2
        assert span > 0.5, (t, span)  # of the view's height: followed, not left behind
        assert np.abs(page.screen_position(["meshcat", "humanoid", "com"])).max() < 0.3
    page.page.click('#views button[data-view="front"]')
    time.sleep(0.3)
    assert page.page.evaluate("humanoidPlayer.view()") == "front"
    page.page.keyboard.press("t")
    time.sleep(0.3)
    assert page.page.evaluate("humanoidPlayer.view()") == "top"
    assert not page.page.is_checked("#follow")  # top stands still
    for t in (0.0, 3.95):
        page.seek(t)
        assert np.abs(page.screen_position(["meshcat", "humanoid", "com"])).max() < 0.95, t
    heel = ["meshcat", "humanoid", "markers", "measured", "R.Heel"]
    page.seek(0.3)  # frame 3: R.Heel missing
    assert not page.visible(heel)
    assert not page.visible(["meshcat", "humanoid", "markers", "residual", "R.Heel"])
    page.seek(0.5)
    assert page.visible(heel)
    k = measured.names.index("R.Heel")
    where = page.page.evaluate(
        "(p) => { const v = new MeshCat.THREE.Vector3(); viewer.scene_tree.find(p).object"
        ".getWorldPosition(v); return [v.x, v.y, v.z]; }",
        heel,
    )
    x, y, z = measured.positions[5, k]
    assert np.allclose(where, [x, z, -y], atol=1e-3)
