"""Open coordarm's logs and a live run in the open-source Foxglove Studio (1.48) in headless Chromium,
take screenshots, and fail on the problems listed in :mod:`checks`.

The app is the web entry ``app.js`` over ``@foxglove/studio-base``'s prebuilt bundle (installed with
``npm ci`` from the pinned ``package-lock.json`` into ``build/viewer``); nothing is compiled. For each
preset: ``coordarm run PRESET`` writes the log, ``coordarm layout --for PRESET`` its layout, the app
opens the log through its remote-file source (``?ds=remote-file``) with that layout (``?layoutId``)
at a time of the run (``?time``), and the page is checked and captured. The live check runs
``coordarm run thread --live --live-wait`` and connects the app to it (``?ds=foxglove-websocket``,
the subprotocol Foxglove Studio 1.48 sends is ``foxglove.websocket.v1``).

Usage (from the repository root; ``make viewer`` runs it for every preset)::

    python tools/viewer/screenshots.py [--presets thread,hole] [--out docs/figures] [--no-live]

Exit status 0 when every check passed, 1 otherwise (each failure printed on one line).
"""
from __future__ import annotations

import argparse
import io
import json
import queue
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

from PIL import Image

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from browser import Browser, StaticServer  # noqa: E402
from checks import canvases, listed_problems, plot_problems, scene_problems  # noqa: E402

ROOT = HERE.parent.parent
PRESETS = ("line", "arc", "hole", "pipe", "thread", "line3d", "path3d", "pipe3d", "port")
#: Where in the run each screenshot is taken [fraction of the log's duration].
AT = 0.6
LIVE_PRESET, LIVE_SPEED = "thread", 1.0
WIDTH, HEIGHT = 1600, 900


def ensure_app(build: Path) -> Path:
    """Install the pinned npm packages into ``build`` (``npm ci``, no install scripts) unless present."""
    bundle = build / "node_modules" / "@foxglove" / "studio-base" / "assets" / "index.js"
    if bundle.is_file():
        return build
    if shutil.which("npm") is None:
        raise SystemExit("viewer: npm not found (Node.js 18 or later is needed to install Foxglove Studio)")
    build.mkdir(parents=True, exist_ok=True)
    for name in ("package.json", "package-lock.json"):
        shutil.copy(HERE / name, build / name)
    subprocess.run(["npm", "ci", "--ignore-scripts", "--no-audit", "--no-fund", "--loglevel=error"], cwd=build,
                   check=True)
    return build


def coordarm(*args: str) -> str:
    """Run ``coordarm ARGS`` with this Python; its standard output."""
    done = subprocess.run([sys.executable, "-m", "coordarm", *args], capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"viewer: coordarm {' '.join(args)} failed:\n{done.stderr.strip()}")
    return done.stdout


def log_end(path: Path) -> float:
    """The last message time of an MCAP log [s]."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        return make_reader(f).get_summary().statistics.message_end_time * 1e-9


def prepare(build: Path, presets: list[str]) -> None:
    """Write each preset's log and fitted layout under ``build`` (logs/, layouts/ with index.json)."""
    (build / "logs").mkdir(exist_ok=True)
    (build / "layouts").mkdir(exist_ok=True)
    for name in presets:
        coordarm("run", name, "--out", str(build / "logs" / f"{name}.mcap"), "--overwrite", "--no-figures",
                 "--quiet")
        coordarm("layout", "--for", name, "--out", str(build / "layouts" / f"{name}.json"))
    (build / "layouts" / "index.json").write_text(json.dumps(presets))


def rfc3339(seconds: float) -> str:
    """A log time [s] as the app's ``?time=`` value."""
    whole = int(seconds)
    stamp = datetime.fromtimestamp(whole, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    return f"{stamp}.{round((seconds - whole) * 1e9):09d}Z"


def close_sidebar(page: Browser) -> None:
    """Close the app's left sidebar (the data source), leaving the panels the whole width."""
    page.evaluate("""(() => { const b = [...document.querySelectorAll('[role=tab], button')]
        .find(e => e.getAttribute('aria-selected') === 'true' && e.closest('[role=tablist]')
              && e.closest('[role=tablist]').getAttribute('aria-orientation') === 'vertical');
        if (b) b.click(); return !!b; })()""")


def scene_items(name: str) -> tuple[bool, bool]:
    """Whether the scene of preset ``name`` has obstacles, and a rail (what the 3D check expects)."""
    from coordarm.simulation.scenario import load_scenario

    scenario = load_scenario(name)
    base = scenario.config.chain.base
    return bool(scenario.obstacles), isinstance(base, dict) and base.get("kind") == "rail"


def check_page(page: Browser, png: bytes, name: str, whole: bool) -> list[str]:
    """Every problem of one screenshot: listed by the app, or a panel that draws nothing (``whole``: the
    plots must reach their right end, the log's end)."""
    found = listed_problems(page)
    rects = canvases(page)
    if not rects:
        return found + ["no panel drew anything (no canvas)"]
    scene = max(rects, key=lambda r: r.w * r.h)
    obstacles, rail = scene_items(name)
    found += scene_problems(png, scene, obstacles=obstacles, rail=rail)
    for rect in rects:
        if rect != scene:
            found += plot_problems(png, rect, whole=whole)
    return found


def capture(page: Browser, url: str, ready_js: str, name: str, settle: float, timeout: float,
            whole: bool = True) -> tuple[bytes, list]:
    """Open ``url``, wait for ``ready_js`` and then ``settle`` seconds, and screenshot until the checks
    pass (or ``timeout``); the last screenshot and its problems (``whole``: as :func:`check_page`)."""
    page.open(url)
    if not page.wait_for(ready_js, timeout):
        return page.screenshot(), [f"the app did not open the data source within {timeout:.0f} s"]
    time.sleep(settle)
    end = time.monotonic() + timeout
    while True:
        close_sidebar(page)
        time.sleep(1.0)
        png = page.screenshot()
        found = check_page(page, png, name, whole)
        if not found or time.monotonic() > end:
            return png, found
        time.sleep(2.0)


def save(png: bytes, path: Path) -> None:
    """Save a screenshot as a small PNG (256-colour palette)."""
    image = Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    image.save(path, optimize=True)


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def live(page: Browser, server: StaticServer, build: Path, out: Path) -> list[str]:
    """Run ``LIVE_PRESET`` live, connect the app to it, screenshot mid-run; its problems."""
    port = free_port()
    errors = build / "logs" / f"{LIVE_PRESET}_live.err"
    err_file = errors.open("w")
    run = subprocess.Popen([sys.executable, "-m", "coordarm", "run", LIVE_PRESET, "--live", "--live-wait",
                            "--port", str(port), "--live-speed", str(LIVE_SPEED), "--overwrite", "--no-figures",
                            "--out", str(build / "logs" / f"{LIVE_PRESET}_live.mcap")],
                           stdout=subprocess.PIPE, stderr=err_file, text=True)
    lines: queue.Queue = queue.Queue()
    reader = threading.Thread(target=lambda: [lines.put(x) for x in run.stdout], daemon=True)
    reader.start()
    try:
        address = None
        end = time.monotonic() + 180
        while address is None and time.monotonic() < end and run.poll() is None:
            try:
                address = re.search(r"ws://127\.0\.0\.1:\d+", lines.get(timeout=1.0))
            except queue.Empty:
                pass
        if address is None:
            return ["coordarm run --live printed no address within 180 s"]
        url = (f"{server.url}/index.html?ds=foxglove-websocket&ds.url=ws://127.0.0.1:{port}"
               f"&layoutId={LIVE_PRESET}")
        ready = "document.body.innerText.includes('/scene')"   # the topic list: the server is connected
        png, found = capture(page, url, ready, LIVE_PRESET, settle=5.0, timeout=10.0, whole=False)
        save(png, out / f"foxglove_live_{LIVE_PRESET}.png")
        run.wait(timeout=120)
        err = errors.read_text()
        if run.returncode:
            found.append(f"the run exited with {run.returncode}: {err.strip()[-300:]}")
        found += [f"the run printed '{m}'" for m in re.findall(r"[^\n]*handshake failed[^\n]*", err)]
        return [f"live: {p}" for p in found]
    finally:
        if run.poll() is None:
            run.terminate()
            run.wait(timeout=20)
        reader.join(timeout=10)       # it ends at the end of the run's output
        if not reader.is_alive():
            run.stdout.close()
        err_file.close()


def main(argv: list[str] | None = None) -> int:
    """Screenshots and checks; the exit status (0: every check passed)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--presets", default=",".join(PRESETS), help="comma-separated presets (default: all)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures", help="where the PNGs go")
    parser.add_argument("--build", type=Path, default=ROOT / "build" / "viewer", help="npm install and logs")
    parser.add_argument("--no-live", action="store_true", help="skip the live view")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per page to pass its checks")
    args = parser.parse_args(argv)
    presets = [p for p in args.presets.split(",") if p]
    build = ensure_app(args.build.resolve())
    prepare(build, sorted(set(presets) | ({LIVE_PRESET} if not args.no_live else set())))
    args.out.mkdir(parents=True, exist_ok=True)
    server = StaticServer({"/": HERE, "/node_modules/": build / "node_modules", "/logs/": build / "logs",
                           "/layouts/": build / "layouts"})
    page = Browser(WIDTH, HEIGHT)
    failures = []
    try:
        for name in presets:
            at = AT * log_end(build / "logs" / f"{name}.mcap")
            url = (f"{server.url}/index.html?ds=remote-file&ds.url={server.url}/logs/{name}.mcap"
                   f"&layoutId={name}&time={rfc3339(at)}")
            png, found = capture(page, url, f"document.body.innerText.includes('{name}.mcap')", name,
                                 settle=6.0, timeout=args.timeout)
            save(png, args.out / f"foxglove_{name}.png")
            print(f"{name}: {'ok' if not found else 'FAILED'} at t = {at:.2f} s -> foxglove_{name}.png")
            failures += [f"{name}: {p}" for p in found]
        if not args.no_live:
            found = live(page, server, build, args.out)
            print(f"live {LIVE_PRESET}: {'ok' if not found else 'FAILED'} -> foxglove_live_{LIVE_PRESET}.png")
            failures += found
    finally:
        page.close()
        server.close()
    for line in failures:
        print(line)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
