"""Reading the user's YAML files with bounds: size, encoding, nesting and alias expansion.

Every YAML the user hands over (``meta.yaml``, a method configuration, a scenario, a sweep, an
import mapping, a ``--set`` value) is read by :func:`load_yaml_file` or :func:`load_yaml_text`,
which raise :class:`inmotion.errors.BadInput` (exit status 2) instead of running out of memory
or stack:

- a file larger than :data:`MAX_BYTES` (64 MiB; a bundle's ``meta.yaml`` is a few kB);
- bytes that are not UTF-8 (the message gives the byte offset);
- nesting deeper than :data:`MAX_DEPTH` (a document 50,000 levels deep would exhaust Python's
  stack);
- a document whose aliases expand to more than :data:`MAX_NODES` nodes and more than ten times
  the nodes it writes out ("billion laughs":
  nine lines of anchors and aliases that expand to 10^9 strings). The expanded size is counted
  on the composed node graph (each node's size computed once) before any Python object is
  built, so the check itself costs no more than the file's own size.
"""
from __future__ import annotations

from pathlib import Path

import yaml

from ..errors import BadInput

__all__ = ["load_yaml_file", "load_yaml_text", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES"]

#: largest YAML file read [bytes]
MAX_BYTES = 64 * 1024 * 1024
#: deepest nesting of mappings and sequences
MAX_DEPTH = 100
#: most nodes a document may expand to once its aliases are resolved, unless that is less than
#: EXPANSION_FACTOR times the nodes written (a large file without aliases is not a bomb)
MAX_NODES = 1_000_000
EXPANSION_FACTOR = 10


def _too_deep(text: str) -> bool:
    """Cheap pre-scan: flow brackets or indentation deeper than MAX_DEPTH (before composing,
    which is recursive and would overflow the stack on a 50,000-deep document)."""
    depth = best = 0
    quote = None
    for ch in text:
        if quote:
            if ch == quote:
                quote = None
            continue
        if ch in "[{":
            depth += 1
            if depth > best:
                best = depth
                if best > MAX_DEPTH:
                    return True
        elif ch in "]}":
            depth = max(0, depth - 1)
        elif ch in "'\"":
            quote = ch
        elif ch == "\n":
            quote = None
    return False


class _Recursive(Exception):
    pass


def _expanded_size(root) -> tuple[int, int, int]:
    """(nodes after alias expansion, nesting depth, distinct nodes) of a composed node graph,
    iteratively."""
    size, depth, visiting = {}, {}, set()
    stack = [(root, False)]
    while stack:
        node, ready = stack.pop()
        key = id(node)
        if key in size or (not ready and key in visiting):
            continue
        if isinstance(node, yaml.ScalarNode):
            size[key], depth[key] = 1, 1
            continue
        children = ([c for kv in node.value for c in kv] if isinstance(node, yaml.MappingNode)
                    else list(node.value))
        if not ready:
            visiting.add(key)
            stack.append((node, True))
            for c in children:
                if id(c) in visiting:
                    raise _Recursive()
                if id(c) not in size:
                    stack.append((c, False))
            continue
        n = 1
        d = 0
        for c in children:
            n += size.get(id(c), 1)        # a child still on the stack is a recursive alias
            d = max(d, depth.get(id(c), 1))
        size[key], depth[key] = min(n, 10**15), d + 1
    return size[id(root)], depth[id(root)], len(size)


def load_yaml_text(text: str, file=None, what: str = "YAML", invalid: str = "malformed YAML"):
    """Parse ``text`` (one document) within the bounds of this module; ``file`` names it in
    messages; ``invalid`` starts the message of a syntax error."""
    if len(text) > MAX_BYTES:
        raise BadInput(f"{what} is {len(text)} characters, more than the {MAX_BYTES} accepted",
                       file=file)
    if _too_deep(text):
        raise BadInput(f"{what} is nested more than {MAX_DEPTH} levels deep", file=file)
    try:
        try:
            return _parse(text, _FAST_LOADER, file, what)
        except yaml.YAMLError:
            if _FAST_LOADER is yaml.SafeLoader:
                raise
        # libyaml's messages are terser ("found undefined alias", no name): the document is
        # parsed again by PyYAML's own parser for its message (a bad file is rare, speed moot)
        return _parse(text, yaml.SafeLoader, file, what)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise BadInput(f"{invalid}{where}: {problem}", file=file) from None
    except RecursionError:
        raise BadInput(f"{what} is nested too deeply", file=file) from None


#: the loader a document is parsed with first: libyaml's (``yaml.CSafeLoader``: the same
#: resolver and constructors as ``yaml.SafeLoader``, its scanner, parser and composer in C,
#: 1.7 ms against 11 ms for a simulated bundle's 4 kB meta.yaml), PyYAML's where libyaml is
#: not installed
_FAST_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _parse(text: str, loader_cls, file, what):
    """One document of ``text`` composed, bounded (alias expansion, depth) and constructed by
    ``loader_cls``; yaml.YAMLError as the loader raises it."""
    loader = loader_cls(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        try:
            n, depth, distinct = _expanded_size(node)
        except _Recursive:
            raise BadInput(f"{what} has an alias (*name) inside the value it names",
                           file=file) from None
        if n > MAX_NODES and n > EXPANSION_FACTOR * distinct:
            raise BadInput(f"{what} expands to more than {MAX_NODES} values through its "
                           "aliases (*name); write the values out", file=file)
        if depth > MAX_DEPTH:
            raise BadInput(f"{what} is nested more than {MAX_DEPTH} levels deep", file=file)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def load_yaml_file(path, what: str = "YAML", invalid: str = "malformed YAML"):
    """Read and parse the YAML file ``path`` within the bounds of this module."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_BYTES:
            raise BadInput(f"file is {size} bytes, more than the {MAX_BYTES} accepted for "
                           f"{what}", file=p)
        raw = p.read_bytes()
    except FileNotFoundError:
        raise BadInput("file not found", file=p) from None
    except IsADirectoryError:
        raise BadInput(f"is a folder, not a {what} file", file=p) from None
    except OSError as e:
        raise BadInput(f"cannot read: {e.strerror or e}", file=p) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise BadInput(f"not UTF-8 text (byte {e.start}: 0x{raw[e.start]:02x}); save the "
                       f"{what} as UTF-8", file=p) from None
    if text.startswith("\ufeff"):
        text = text[1:]
    return load_yaml_text(text, file=p, what=what, invalid=invalid)
