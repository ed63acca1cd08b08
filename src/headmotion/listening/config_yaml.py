"""YAML composed with line numbers, and the validation helpers of the listening-test
configuration (:mod:`headmotion.listening.config`): every value keeps the line it came from, so
an error names the file and the line."""

from __future__ import annotations

from pathlib import Path

import yaml

from ..errors import FormatError


class _Node:
    """A plain value together with the line (1-based) it came from."""

    __slots__ = ("value", "line")

    def __init__(self, value, line):
        self.value = value
        self.line = line


def _convert(node: yaml.Node, path: Path) -> _Node:
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, _Node] = {}
        keylines: dict[str, int] = {}
        for knode, vnode in node.value:
            if not isinstance(knode, yaml.ScalarNode):
                raise FormatError("mapping keys must be plain strings", path=path,
                                  line=knode.start_mark.line + 1)
            key = str(knode.value)
            if key in out:
                raise FormatError(f"duplicate key {key!r} (first on line {keylines[key]})",
                                  path=path, line=knode.start_mark.line + 1)
            keylines[key] = knode.start_mark.line + 1
            out[key] = _convert(vnode, path)
        return _Node(out, line)
    if isinstance(node, yaml.SequenceNode):
        return _Node([_convert(v, path) for v in node.value], line)
    return _Node(_scalar(node), line)


_RESOLVER_LOADER = yaml.SafeLoader("")


def _scalar(node: yaml.ScalarNode):
    # construct the scalar with PyYAML's own resolver/constructors (ints, floats, bools, null)
    return _RESOLVER_LOADER.construct_object(node, deep=True)


def _compose(text: str, path: Path) -> _Node:
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        msg = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        raise FormatError(f"invalid YAML: {msg}", path=path, line=line) from None
    except yaml.YAMLError as exc:
        raise FormatError(f"invalid YAML: {exc}", path=path) from None
    if root is None:
        raise FormatError("the file is empty; expected a mapping with at least 'type' and 'items'",
                          path=path, line=1)
    return _convert(root, path)


class _Ctx:
    """Validation helpers that raise :class:`FormatError` with the file and line."""

    def __init__(self, path: Path, root_dir: Path):
        self.path = path
        self.root_dir = root_dir

    def fail(self, msg: str, node: _Node | None) -> None:
        raise FormatError(msg, path=self.path, line=None if node is None else node.line)

    def mapping(self, node: _Node, what: str) -> dict[str, _Node]:
        if not isinstance(node.value, dict):
            self.fail(f"{what} must be a mapping; got {type(node.value).__name__} {node.value!r}"
                      if not isinstance(node.value, list) else f"{what} must be a mapping; got a list",
                      node)
        return node.value

    def seq(self, node: _Node, what: str) -> list[_Node]:
        if not isinstance(node.value, list):
            self.fail(f"{what} must be a list; got {_show(node)}", node)
        return node.value

    def string(self, node: _Node, what: str, *, allow_empty: bool = False) -> str:
        if isinstance(node.value, (dict, list)) or node.value is None:
            self.fail(f"{what} must be a string; got {_show(node)}", node)
        s = str(node.value)
        if not s.strip() and not allow_empty:
            self.fail(f"{what} must not be empty", node)
        return s

    def integer(self, node: _Node, what: str, lo: int | None = None, hi: int | None = None) -> int:
        v = node.value
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(f"{what} must be an integer; got {_show(node)}", node)
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            rng = f"[{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]"
            self.fail(f"{what} must be an integer in the range {rng}; got {v}", node)
        return int(v)

    def number(self, node: _Node, what: str, lo: float, hi: float) -> float:
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(f"{what} must be a number; got {_show(node)}", node)
        if not lo <= v <= hi:
            self.fail(f"{what} must be in the range [{lo}, {hi}]; got {v}", node)
        return float(v)

    def boolean(self, node: _Node, what: str) -> bool:
        if not isinstance(node.value, bool):
            self.fail(f"{what} must be true or false; got {_show(node)}", node)
        return bool(node.value)

    def keys(self, m: dict[str, _Node], allowed: set[str], what: str, _node: _Node) -> None:
        for k, v in m.items():
            if k not in allowed:
                self.fail(f"unknown key {k!r} in {what}; expected one of {sorted(allowed)}", v)

    def file(self, node: _Node, what: str, suffixes: tuple[str, ...]) -> Path:
        rel = self.string(node, what)
        p = Path(rel)
        if p.is_absolute():
            self.fail(f"{what} {rel!r} must be a path relative to the test folder {self.root_dir}",
                      node)
        full = (self.root_dir / p).resolve()
        if not full.is_relative_to(self.root_dir):
            self.fail(f"{what} {rel!r} leaves the test folder {self.root_dir}", node)
        if full.suffix.lower() not in suffixes:
            self.fail(f"{what} {rel!r} has an unsupported extension; expected one of "
                      f"{', '.join(suffixes)}", node)
        if not full.is_file():
            self.fail(f"{what} {rel!r} does not exist (looked for {full})", node)
        return full


def _show(node: _Node) -> str:
    v = node.value
    if isinstance(v, dict):
        return "a mapping"
    if isinstance(v, list):
        return "a list"
    return f"{type(v).__name__} {v!r}"
