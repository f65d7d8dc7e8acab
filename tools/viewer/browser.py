"""Headless Chromium driven over the DevTools protocol, and a static HTTP server with byte ranges.

The two pieces the viewer check needs and nothing more: :class:`StaticServer` serves the Foxglove
Studio web app, the layouts and the logs on 127.0.0.1 (Foxglove's remote-file source reads MCAP
files with HTTP range requests, which :mod:`http.server` does not answer), and :class:`Browser`
starts the system Chromium (no browser download) and drives one page through the Chrome DevTools
Protocol with the ``websockets`` package.
"""
from __future__ import annotations

import base64
import json
import mimetypes
import re
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.request
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, Callable
from urllib.parse import unquote, urlsplit

from websockets.sync.client import connect

#: Content types the app needs beyond :mod:`mimetypes`' defaults.
CONTENT_TYPES = {".wasm": "application/wasm", ".js": "text/javascript", ".mcap": "application/octet-stream",
                 ".json": "application/json"}


class StaticServer:
    """Serve files under URL prefixes on 127.0.0.1, answering ``Range: bytes=a-b`` requests.

    Parameters
    ----------
    routes : dict[str, pathlib.Path]
        URL prefix (``"/"``, ``"/logs/"``) -> directory; the longest matching prefix wins.
    port : int
        TCP port (0: any free port, read back from :attr:`port`).
    """

    def __init__(self, routes: dict[str, Path], port: int = 0) -> None:
        self.routes = sorted(((p, Path(d)) for p, d in routes.items()), key=lambda r: -len(r[0]))
        self.httpd = ThreadingHTTPServer(("127.0.0.1", port), _make_handler(self.resolve))
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return self.httpd.server_address[1]

    @property
    def url(self) -> str:
        """``http://127.0.0.1:PORT``."""
        return f"http://127.0.0.1:{self.port}"

    def resolve(self, url_path: str) -> Path | None:
        """The file a URL path names, or None (outside every route, or missing)."""
        for prefix, folder in self.routes:
            if url_path.startswith(prefix):
                rest = url_path[len(prefix):] or "index.html"
                path = (folder / rest).resolve()
                base = folder.resolve()
                if (path == base or base in path.parents) and path.is_file():
                    return path
                return None
        return None

    def close(self) -> None:
        """Stop serving."""
        self.httpd.shutdown()
        self.httpd.server_close()


def _make_handler(resolve: Callable[[str], Path | None]) -> type:
    class Handler(BaseHTTPRequestHandler):
        def do_HEAD(self) -> None:
            self.answer(body=False)

        def do_GET(self) -> None:
            self.answer(body=True)

        def answer(self, body: bool) -> None:
            path = resolve(unquote(urlsplit(self.path).path))
            if path is None:
                self.send_error(404)
                return
            size = path.stat().st_size
            start, end, status = 0, size - 1, 200
            match = re.fullmatch(r"bytes=(\d*)-(\d*)", self.headers.get("Range", "").strip())
            if match and (match[1] or match[2]):
                if match[1]:
                    start, end = int(match[1]), min(int(match[2]) if match[2] else size - 1, size - 1)
                else:
                    start = max(size - int(match[2]), 0)
                if start > end:
                    self.send_response(416)
                    self.send_header("Content-Range", f"bytes */{size}")
                    self.end_headers()
                    return
                status = 206
            self.send_response(status)
            kind = CONTENT_TYPES.get(path.suffix) or mimetypes.guess_type(path.name)[0] or "application/octet-stream"
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(end - start + 1))
            self.send_header("Accept-Ranges", "bytes")
            self.send_header("Cache-Control", "no-store")
            if status == 206:
                self.send_header("Content-Range", f"bytes {start}-{end}/{size}")
            self.end_headers()
            if body:
                with path.open("rb") as f:
                    f.seek(start)
                    left = end - start + 1
                    while left > 0 and (data := f.read(min(left, 1 << 20))):
                        try:
                            self.wfile.write(data)
                        except (BrokenPipeError, ConnectionResetError):
                            return
                        left -= len(data)

        def log_message(self, *args: Any) -> None:  # quiet
            pass

    return Handler


def chromium_path() -> str | None:
    """The system Chromium (``chromium``, ``chromium-browser`` or ``google-chrome`` on PATH), or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if found := shutil.which(name):
            return found
    return None


class Browser:
    """One headless Chromium page driven over the DevTools protocol.

    Parameters
    ----------
    width, height : int
        Window size [CSS px] (the screenshots' size).
    executable : str, optional
        The browser; default :func:`chromium_path`.
    """

    def __init__(self, width: int = 1600, height: int = 1000, executable: str | None = None) -> None:
        exe = executable or chromium_path()
        if exe is None:
            raise RuntimeError("no Chromium on PATH (apt-get install chromium)")
        self.profile = Path(tempfile.mkdtemp(prefix="coordarm-chromium-"))
        self.proc = subprocess.Popen(
            [exe, "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--mute-audio",
             "--no-first-run", "--disable-dev-shm-usage", f"--window-size={width},{height}",
             "--remote-debugging-port=0", f"--user-data-dir={self.profile}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.console: list[str] = []
        self.next_id = 0
        port = self._devtools_port()
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as answer:
            pages = [t for t in json.load(answer) if t["type"] == "page"]
        self.ws = connect(pages[0]["webSocketDebuggerUrl"], max_size=None, open_timeout=20, ping_interval=None,
                          close_timeout=2)   # a local connection: no keepalive pings (Chromium answers no close frame)
        self.call("Page.enable")
        self.call("Runtime.enable")
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1,
                  mobile=False)

    def _devtools_port(self, timeout: float = 30.0) -> int:
        marker = self.profile / "DevToolsActivePort"
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if marker.exists() and (lines := marker.read_text().splitlines()):
                return int(lines[0])
            if self.proc.poll() is not None:
                raise RuntimeError(f"Chromium exited with code {self.proc.returncode} at start-up")
            time.sleep(0.1)
        raise RuntimeError("Chromium did not open its DevTools port within 30 s")

    def call(self, method: str, timeout: float = 60.0, **params: Any) -> dict[str, Any]:
        """Send one DevTools command and return its result (events met meanwhile are recorded)."""
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        end = time.monotonic() + timeout
        while True:
            message = json.loads(self.ws.recv(timeout=max(end - time.monotonic(), 0.01)))
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            self._event(message)

    def _event(self, message: dict[str, Any]) -> None:
        method, params = message.get("method"), message.get("params", {})
        if method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "warning"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in params.get("args", []))
            self.console.append(f"{params['type']}: {text[:300]}")
        elif method == "Runtime.exceptionThrown":
            details = params.get("exceptionDetails", {})
            self.console.append(f"exception: {details.get('exception', {}).get('description', details.get('text'))}"
                                [:300])

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (awaited if it is a promise)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"page script failed: {result['exceptionDetails'].get('text')}")
        return result["result"].get("value")

    def open(self, url: str) -> None:
        """Navigate the page to ``url``."""
        self.call("Page.navigate", url=url)

    def wait_for(self, expression: str, timeout: float, poll: float = 0.5) -> bool:
        """Poll a JavaScript expression until it is truthy; False after ``timeout`` seconds."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                if self.evaluate(expression):
                    return True
            except RuntimeError:  # the page is between documents
                pass
            time.sleep(poll)
        return False

    def screenshot(self) -> bytes:
        """A PNG of the page as it is drawn now."""
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])

    def close(self) -> None:
        """Close the connection and end the browser (only the process this object started)."""
        try:
            self.ws.close()
        except Exception:  # noqa: BLE001  the browser may drop the connection first; it is ended below
            pass
        finally:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
            shutil.rmtree(self.profile, ignore_errors=True)
