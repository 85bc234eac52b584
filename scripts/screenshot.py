#!/usr/bin/env python3
"""Screenshot of the viewer for the docs: the pushed body, exported as HTML, in chromium.

Needs Debian's chromium and Playwright (the test extras). Writes docs/viewer.png.
Usage: python scripts/screenshot.py [--out docs/viewer.png] [--time 0.7]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import humanoid as hm
from humanoid.viewer import export_html

ROOT = Path(__file__).resolve().parent.parent
FLAGS = ["--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync"]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "viewer.png"))
    parser.add_argument("--time", type=float, default=0.7, help="animation time to show [s]")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    scene = hm.Scene.load("push").replace(duration=1.2)
    traj = hm.simulate(scene, quiet=True)
    h = hm.load("adult_male")
    with tempfile.TemporaryDirectory() as tmp:
        page_file = export_html(h, Path(tmp) / "push.html", traj=traj, title="push")
        with sync_playwright() as p:
            ctx = p.chromium.launch_persistent_context(
                str(Path(tmp) / "profile"), executable_path="/usr/bin/chromium", headless=True,
                args=FLAGS, viewport={"width": 640, "height": 480},
            )  # fmt: skip
            page = ctx.new_page()
            page.goto(page_file.as_uri())
            page.wait_for_function("() => window.humanoidReady", timeout=60_000)
            time.sleep(2.0)
            page.evaluate(  # from the side: the push (along x) and the feet's forces
                f"() => {{ viewer.animator.pause(); viewer.animator.seek({args.time});"
                " viewer.camera.position.set(0.9, 0.5, 2.7); viewer.set_dirty(); }"
            )
            time.sleep(1.0)
            out = Path(args.out)
            out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(out))
            ctx.close()
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
