"""A thin TCP layer in front of foxglove-sdk's WebSocket server that also accepts the older subprotocol name.

foxglove-sdk (0.30, the newest release) accepts only the WebSocket subprotocols ``foxglove.sdk.v1``
and ``foxglove.sdk.v1.1``; the open-source viewers (Foxglove Studio 1.48, Lichtblick before its
``foxglove.sdk.v1`` support) offer ``foxglove.websocket.v1``, the same protocol under its former
name, and the SDK refuses their handshake. The SDK has no option for it, so this bridge listens on
the public port, and for each connection:

1. reads the client's HTTP upgrade request; if it offers ``foxglove.websocket.v1`` but no
   ``foxglove.sdk.*`` name, it asks the SDK for ``foxglove.sdk.v1`` instead;
2. passes the SDK's answer back, naming the subprotocol the client asked for (the
   ``Sec-WebSocket-Accept`` key depends on ``Sec-WebSocket-Key`` only, which is left alone);
3. then copies bytes both ways unchanged.

A client that stops reading blocks only its own copying thread: the SDK then drops that client's
oldest messages (its per-client backlog) or disconnects it, and the run goes on at its pace; a
send that stays blocked for :data:`STALL_TIMEOUT` seconds closes that connection.
"""
from __future__ import annotations

import re
import socket
import struct
import threading
from typing import Any

#: The subprotocol foxglove-sdk serves, and the former name the open-source viewers send.
SDK_SUBPROTOCOL, LEGACY_SUBPROTOCOL = "foxglove.sdk.v1", "foxglove.websocket.v1"

#: Longest accepted HTTP upgrade request or answer [bytes].
MAX_HEADER = 64 * 1024

#: A client whose socket has not taken a byte for this long is disconnected [s].
STALL_TIMEOUT = 20.0

#: Kernel buffer of each side of a bridged connection [bytes]: bounded, so that a slow client's backlog
#: stays in the SDK's per-client queue, which drops the oldest messages (fresher data, bounded memory).
SOCKET_BUFFER = 256 * 1024

_PROTOCOL_LINE = re.compile(rb"^sec-websocket-protocol:[ \t]*(.*?)[ \t]*$", re.IGNORECASE | re.MULTILINE)


def offered_subprotocols(request: bytes) -> list[str]:
    """The subprotocols an HTTP upgrade request offers, in order (every ``Sec-WebSocket-Protocol`` line).

    Parameters
    ----------
    request : bytes
        The request head, up to and including the blank line (lines end in CRLF).

    Returns
    -------
    list of str
        The offered names.
    """
    head = request.replace(b"\r\n", b"\n")
    return [name.strip() for line in _PROTOCOL_LINE.findall(head)
            for name in line.decode("latin-1").split(",") if name.strip()]


def _replace_protocol(head: bytes, name: str) -> bytes:
    """``head`` with its ``Sec-WebSocket-Protocol`` lines replaced by one naming ``name``."""
    lines = head.split(b"\r\n")
    out, done = [], False
    for line in lines:
        if line.lower().startswith(b"sec-websocket-protocol:"):
            if not done:
                out.append(b"Sec-WebSocket-Protocol: " + name.encode())
                done = True
            continue
        out.append(line)
    return b"\r\n".join(out)


def rewrite_request(request: bytes) -> tuple[bytes, str | None]:
    """The request to send to the SDK, and the name to restore in its answer (None: unchanged).

    Parameters
    ----------
    request : bytes
        The client's request head (ending in a blank line).

    Returns
    -------
    request : bytes
        The head for the SDK: ``foxglove.sdk.v1`` in place of ``foxglove.websocket.v1`` when the
        client offers only the latter of the two names.
    restore : str or None
        ``foxglove.websocket.v1`` when the request was rewritten.
    """
    offered = offered_subprotocols(request)
    if LEGACY_SUBPROTOCOL in offered and not any(p.startswith("foxglove.sdk.") for p in offered):
        return _replace_protocol(request, SDK_SUBPROTOCOL), LEGACY_SUBPROTOCOL
    return request, None


def rewrite_answer(answer: bytes, restore: str | None) -> bytes:
    """The SDK's answer head as the client must see it (its subprotocol renamed to ``restore``).

    Parameters
    ----------
    answer : bytes
        The SDK's response head (ending in a blank line).
    restore : str or None
        The name to give the chosen subprotocol (None: unchanged).

    Returns
    -------
    bytes
        The head for the client.
    """
    if restore is None or not _PROTOCOL_LINE.search(answer.replace(b"\r\n", b"\n")):
        return answer
    return _replace_protocol(answer, restore)


def _read_head(sock: socket.socket) -> tuple[bytes, bytes]:
    """Read up to the end of an HTTP head: ``(head, bytes after it)``; ``(b"", b"")`` if the peer closed first."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(4096)
        if not chunk or len(data) > MAX_HEADER:
            return b"", b""
        data += chunk
    end = data.index(b"\r\n\r\n") + 4
    return data[:end], data[end:]


def _pump(src: socket.socket, dst: socket.socket, done: threading.Event) -> None:
    """Copy bytes from ``src`` to ``dst`` until either side closes or stalls; then close both."""
    try:
        while not done.is_set():
            chunk = src.recv(65536)
            if not chunk:
                break
            dst.sendall(chunk)
    except OSError:   # reset, closed by the other pump, or a send stalled past its timeout
        pass
    finally:
        done.set()
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()


class SubprotocolBridge:
    """Listen on ``(host, port)`` and pass every connection to the SDK server at ``upstream``.

    Parameters
    ----------
    upstream : tuple of (str, int)
        Address of foxglove-sdk's server (on the loopback interface).
    host : str
        Address to listen on.
    port : int
        Port to listen on (0: any free port, see :attr:`port`).

    Raises
    ------
    OSError
        The port is in use or the host is not an address of this machine.
    """

    def __init__(self, upstream: tuple[str, int], host: str = "127.0.0.1", port: int = 8765) -> None:
        self.upstream = upstream
        self._listener = socket.create_server((host, port), reuse_port=False)
        self._listener.settimeout(0.2)
        self._open: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._accept, name="coordarm-live-bridge", daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The port the bridge listens on."""
        return self._listener.getsockname()[1]

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                client, _ = self._listener.accept()
            except socket.timeout:
                continue
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), name="coordarm-live-client", daemon=True).start()

    def _track(self, *socks: Any) -> None:
        with self._lock:
            self._open.update(socks)

    def _serve(self, client: socket.socket) -> None:
        upstream = None
        try:
            client.settimeout(STALL_TIMEOUT)
            request, rest = _read_head(client)
            if not request:
                client.close()
                return
            request, restore = rewrite_request(request)
            client.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCKET_BUFFER)
            upstream = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            upstream.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, SOCKET_BUFFER)
            upstream.settimeout(STALL_TIMEOUT)
            upstream.connect(self.upstream)
            self._track(client, upstream)
            upstream.sendall(request + rest)
            answer, more = _read_head(upstream)
            if not answer:
                raise OSError("the live server closed the connection during the handshake")
            client.sendall(rewrite_answer(answer, restore) + more)
            # from here on both sides may stay silent for long: no timeout on reads, only on the
            # client's sends (a client that takes no byte for STALL_TIMEOUT seconds is dropped)
            upstream.settimeout(None)
            client.settimeout(None)
            client.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, struct.pack("ll", int(STALL_TIMEOUT), 0))
        except OSError:
            for s in (client, upstream):
                if s is not None:
                    s.close()
            return
        done = threading.Event()
        threading.Thread(target=_pump, args=(client, upstream, done), daemon=True).start()
        _pump(upstream, client, done)
        with self._lock:
            self._open.difference_update((client, upstream))

    def close(self) -> None:
        """Stop listening and close every open connection."""
        self._stop.set()
        self._listener.close()
        self._thread.join(timeout=2)
        with self._lock:
            socks, self._open = list(self._open), set()
        for s in socks:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()
