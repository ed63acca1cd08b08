"""API keys and per-key limits of ``headmotion serve``.

Keys are stored hashed: a key file holds one line per key,
``sha256:HEX [name=NAME] [streams=N] [rate=N]`` (``#`` starts a comment), made by
``headmotion serve hash-key`` (:func:`key_line`).  A key is a random 32-byte token, so a plain
SHA-256 of it is as hard to invert as the token is to guess (password hashes such as scrypt exist
for low-entropy secrets; they would cost milliseconds on every request).  A presented key is
hashed and looked up; the comparison runs in constant time (:func:`hmac.compare_digest`).

Keys arrive only as ``Authorization: Bearer KEY`` (on the WebSocket handshake too; a browser,
whose WebSocket API cannot set headers, may put the key in the stream's first message instead) —
never in a URL, and never written to a log: a request is logged under the key's name.

Limits per key: concurrent streams (:class:`Slots`) and requests per minute over offline calls and
stream openings together (:class:`RateLimiter`, a token bucket refilled continuously).  Without a
key file the server runs for one local developer: every request is the key ``local``.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from ..errors import FormatError, ParameterError

#: limits of a key whose line names none
DEFAULT_STREAMS = 8
DEFAULT_RATE = 120  # requests (offline calls + stream openings) per minute


@dataclass(frozen=True)
class Key:
    """One key's identity and limits (never the key itself)."""

    name: str
    streams: int = DEFAULT_STREAMS
    rate: int = DEFAULT_RATE


#: the one caller of a server without keys (a developer on localhost): the worker's own stream limit
#: (``Limits.max_streams``) and a rate no local test reaches
LOCAL = Key("local", streams=10_000, rate=60_000)


def hash_key(key: str) -> str:
    """``sha256:HEX`` of a key (what the key file stores)."""
    return "sha256:" + hashlib.sha256(key.encode("utf-8")).hexdigest()


def new_key() -> str:
    """A fresh random key (URL-safe text, 256 bits)."""
    return "hm_" + secrets.token_urlsafe(32)


def key_line(key: str, *, name: str, streams: int = DEFAULT_STREAMS, rate: int = DEFAULT_RATE) -> str:
    """The key file's line for ``key``."""
    if not name or any(c.isspace() or c == "=" for c in name):
        raise ParameterError(f"a key's name must be one word without '='; got {name!r}")
    return f"{hash_key(key)} name={name} streams={int(streams)} rate={int(rate)}"


def _positive(path: Path, n: int, field: str, value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        v = 0
    if v < 1:
        raise FormatError(f"{field} must be a whole number >= 1; got {value!r}", path=path, line=n)
    return v


def load_keys(path) -> dict[str, Key]:
    """The key file as hash → :class:`Key`.

    Raises
    ------
    FormatError
        A line that is not ``sha256:HEX [name=..] [streams=N] [rate=N]``; a file without keys."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"cannot read the key file ({exc})", path=p) from None
    keys: dict[str, Key] = {}
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        digest, *fields = line.split()
        hexpart = digest[len("sha256:"):]
        if not digest.startswith("sha256:") or len(hexpart) != 64 or any(c not in "0123456789abcdef" for c in hexpart):
            raise FormatError("expected 'sha256:<64 hex digits> [name=NAME] [streams=N] [rate=N]' "
                              "(make lines with `headmotion serve hash-key`)", path=p, line=n)
        opts = {"name": f"key{n}", "streams": DEFAULT_STREAMS, "rate": DEFAULT_RATE}
        for f in fields:
            k, sep, v = f.partition("=")
            if not sep or k not in opts:
                raise FormatError(f"unknown field {f!r}; expected name=, streams=, rate=", path=p, line=n)
            opts[k] = v if k == "name" else _positive(p, n, k, v)
        keys[digest] = Key(str(opts["name"]), int(opts["streams"]), int(opts["rate"]))
    if not keys:
        raise FormatError("holds no key (make lines with `headmotion serve hash-key`)", path=p)
    return keys


class KeyStore:
    """Who a request is: :meth:`identify` maps an ``Authorization`` header to a :class:`Key`.

    With ``path`` (the key file), the file is read again when it changes (checked at most every
    ``check_every`` seconds, on the next request): a key added or removed there is honoured
    without a restart.  A file that no longer reads keeps the keys in force and logs why."""

    def __init__(self, keys: dict[str, Key] | None, *, path=None, check_every: float = 1.0, clock=time.monotonic):
        self.keys = keys  # None: no keys, the local developer's server
        self.path = None if path is None else Path(path)
        self.check_every, self.clock = check_every, clock
        self._checked = clock()
        self._seen = self._signature()
        self._lock = threading.Lock()

    @property
    def required(self) -> bool:
        return self.keys is not None

    def _signature(self):
        try:
            st = self.path.stat()
        except (OSError, AttributeError):
            return None
        return (st.st_mtime_ns, st.st_size, st.st_ino)

    def reload_if_changed(self) -> bool:
        """Read the key file again if it changed since it was last read; True when keys changed."""
        if self.path is None or self.clock() - self._checked < self.check_every:
            return False
        with self._lock:
            self._checked = self.clock()
            sig = self._signature()
            if sig is None or sig == self._seen:
                return False
            self._seen = sig
            from .metrics import log_event

            try:
                keys = load_keys(self.path)
            except FormatError as exc:
                log_event("keys_reload_failed", error=str(exc), kept=len(self.keys or {}))
                return False
            self.keys = keys
            log_event("keys_reloaded", keys=len(keys))
            return True

    def identify(self, authorization: str | None) -> Key | None:
        """The key of ``Authorization: Bearer KEY``, :data:`LOCAL` when no keys are configured,
        None when the header is missing, malformed or names no key."""
        if self.keys is None:
            return LOCAL
        self.reload_if_changed()
        if not authorization:
            return None
        scheme, _, token = authorization.strip().partition(" ")
        if scheme.lower() != "bearer" or not token.strip():
            return None
        digest = hash_key(token.strip())
        found = None
        for h, key in self.keys.items():  # constant time in the key, whatever matches
            if hmac.compare_digest(h, digest):
                found = key
        return found


class RateLimiter:
    """Token bucket per key: ``rate`` requests per minute, bursts up to ``rate`` / 6 (10 s)."""

    def __init__(self, clock=time.monotonic):
        self.clock, self.state, self.lock = clock, {}, threading.Lock()

    def allow(self, key: Key) -> bool:
        cap = max(1.0, key.rate / 6.0)
        now = self.clock()
        with self.lock:
            tokens, last = self.state.get(key.name, (cap, now))
            tokens = min(cap, tokens + (now - last) * key.rate / 60.0)
            ok = tokens >= 1.0
            self.state[key.name] = (tokens - 1.0 if ok else tokens, now)
        return ok


class Slots:
    """Concurrent streams per key, and connections not yet started (their key not yet known), which
    count toward the worker's stream limit (:meth:`load`) as open streams do."""

    def __init__(self):
        self.open: dict[str, int] = {}
        self.pending = 0
        self.lock = threading.Lock()

    def enter(self) -> None:
        """A connection admitted, not yet a stream."""
        with self.lock:
            self.pending += 1

    def leave(self) -> None:
        """A connection admitted earlier became a stream or went away."""
        with self.lock:
            self.pending = max(0, self.pending - 1)

    def load(self) -> int:
        """Open streams plus connections not yet started."""
        with self.lock:
            return sum(self.open.values()) + self.pending

    def take(self, key: Key) -> bool:
        with self.lock:
            n = self.open.get(key.name, 0)
            if n >= key.streams:
                return False
            self.open[key.name] = n + 1
            return True

    def give(self, key: Key) -> None:
        with self.lock:
            self.open[key.name] = max(0, self.open.get(key.name, 1) - 1)

    def total(self) -> int:
        with self.lock:
            return sum(self.open.values())


__all__ = ["Key", "LOCAL", "KeyStore", "RateLimiter", "Slots", "hash_key", "new_key", "key_line", "load_keys"]
