"""Safe YAML reading for problem files, with the line of every key path.

What :func:`read_yaml` guarantees, before anything is constructed:

- libyaml's parser/composer (PyYAML's ``CSafeLoader`` when available), SafeLoader's
  construction; no tags (so no Python objects), no anchors, no aliases;
- duplicate keys refused (compared as constructed values, so ``1`` and ``0x1`` clash),
  as are non-scalar keys;
- caps: ``MAX_FILE_BYTES`` of text (checked by the caller before reading), ``MAX_DEPTH``
  levels of nesting and ``MAX_NODES`` values (both checked on the event stream, so a
  hostile file costs no more than reading it);
- a ``lines`` map from every key path (``("arms", 1, "links")``) to its line;
  :func:`line_of` gives the line of a path or of its nearest recorded ancestor;
- ``keep_text``: at the key paths it selects (names, ids), a plain scalar is kept as the text
  written, never coerced by YAML 1.1's implicit types (``no`` -> false, ``0x10`` -> 16,
  ``012`` -> 10, ``1_000`` -> 1000, ``12:30`` -> 750); only ``null``/``~``/empty stays null;
- numbers everywhere as YAML 1.2 reads them: ``1:30``, ``0_3``, ``0b11`` are strings (refused
  where a number is expected), ``010`` is ten; an integer of more than ``MAX_INT_DIGITS`` digits
  is refused with its line.

Every problem is raised as :class:`~coplan.errors.ProblemError`. This module must not
import :mod:`coplan.problem.load` (which imports it).
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from typing import Any

import yaml

from ..errors import InputError, Issue, ProblemError, special_file

MAX_FILE_BYTES = 4 * 1024 * 1024
MAX_DEPTH = 12
MAX_NODES = 300_000  # YAML nodes (scalars + collections); 20 000 fruit take about 180 000


def path_str(loc) -> str:
    """A key path as written in messages: ``("arms", 0, "links")`` -> ``arms[0].links``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


class _LineLoader(yaml.SafeLoader):
    """SafeLoader; duplicate keys, aliases, anchors and tags are refused beforehand by
    :func:`_scan_events` and :func:`_walk_nodes`, then the checked node tree is constructed."""


class _FastLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """libyaml's parser when PyYAML has it (it nearly always does): the same events and marks,
    an order of magnitude faster. Only its parser/composer is used; construction is SafeLoader's.

    Its resolver also reads numbers in scientific notation without a dot (``8e1``, ``1e-3``,
    ``1e308``) as numbers, as YAML 1.2 and every other tool do; YAML 1.1's float rule wants
    ``8.0e+1`` and would make them strings."""


# Numbers as YAML 1.2 (its core schema) reads them, as every other tool does: YAML 1.1's forms
# read a typo as another number, silently -- ``1:30`` as 90 (base 60), ``0_3`` as 3, ``010`` as 8
# (octal). Those are strings now (so "expected a number, found string '1:30'"); ``0x10`` and
# ``0o17`` stay numbers, as in YAML 1.2; scientific notation needs no dot (``8e1``, ``1e-3``).
_INT, _FLOAT = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_FastLoader.add_implicit_resolver(_FLOAT, re.compile("x^"), [])  # (gives this class its own copy of the table)
_FastLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in rules if tag not in (_INT, _FLOAT)]
    for first, rules in _FastLoader.yaml_implicit_resolvers.items()}
_FastLoader.add_implicit_resolver(_INT, re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789"))
_FastLoader.add_implicit_resolver(
    _FLOAT, re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))

#: The most digits an integer in a coplan file may have: more is no plausible value of any key,
#: and converting it to a float (every check does) overflowed, an internal error.
MAX_INT_DIGITS = 30


def _int_out_of_range(text: str) -> str | None:
    """The message for an integer written with more than :data:`MAX_INT_DIGITS` digits, or None."""
    digits = text.lstrip("+-")
    return f"expected a number coplan can hold, found an integer of {len(digits)} digits" if len(digits) > MAX_INT_DIGITS else None


def _float_out_of_range(text: str, value: float) -> str | None:
    """The message for a float ``text`` that reads as ``value`` beyond a float's range (``1e400``;
    ``.inf`` is not), or None."""
    if math.isinf(value) and ".inf" not in text.lower():
        return f"expected a number coplan can hold, found {text} (beyond a float's range)"
    return None


def _construct_int(loader, node):
    """YAML 1.2's integers: decimal (``010`` is ten, not YAML 1.1's octal eight), ``0o`` octal,
    ``0x`` hexadecimal; one of more than :data:`MAX_INT_DIGITS` digits is refused with its line."""
    text = loader.construct_scalar(node)
    digits = text.lstrip("+-")
    far = _int_out_of_range(text)
    if far is not None:
        raise yaml.constructor.ConstructorError(None, None, far, node.start_mark)
    if digits[:2] in ("0o", "0x"):
        return int(digits[2:], 8 if digits[1] == "o" else 16)
    return int(text, 10)


_LineLoader.add_constructor(_INT, _construct_int)


def _construct_float(loader, node):
    """YAML's floats; a number written beyond a float's range (``1e400``) is refused with its line,
    as written -- it became ``inf``, and a message then said "found number inf" of a value the file
    never held (``.inf`` itself stays infinity, for the checks that refuse it by name)."""
    value = yaml.SafeLoader.construct_yaml_float(loader, node)
    far = _float_out_of_range(loader.construct_scalar(node), value)
    if far is not None:
        raise yaml.constructor.ConstructorError(None, None, far, node.start_mark)
    return value


_LineLoader.add_constructor(_FLOAT, _construct_float)


#: aliases and anchors said one by one; the rest of a file's in one issue (a file of a few lines
#: can hold hundreds: each said at its key path buried the message)
ALIASES_SAID = 5
_NO_ALIASES = " (YAML anchors and aliases are not supported)"


def _scan_events(text: str, issues: list) -> bool:
    """Walk the YAML event stream (no recursion, nothing built) tracking key paths.

    Reports every alias and anchor (a few aliases can expand into gigabytes); stops at once
    at nesting deeper than ``MAX_DEPTH`` (which would overflow the recursive composer) or
    more than ``MAX_NODES`` values (a hostile file), so those cost no more than reading the
    file. Issues are appended to ``issues``; returns whether it stopped at ``MAX_NODES``. The
    first ``ALIASES_SAID`` aliases and anchors are said one by one, the rest in one issue.
    """
    more: list = []  # (path, line) of the aliases and anchors past the first ALIASES_SAID
    try:
        return _scan(text, issues, more)
    finally:
        if more:
            (path, line), last = more[0], more[-1][1]
            where = f"line {line}" if last == line else f"lines {line}-{last}"
            what = "more anchor or alias" if len(more) == 1 else "more anchors and aliases"
            issues.append(Issue(path, f"expected plain values, found {len(more)} {what} ({where}){_NO_ALIASES}", line))


def _scan(text: str, issues: list, more: list) -> bool:
    """:func:`_scan_events`' walk; aliases and anchors past the first ``ALIASES_SAID`` go to ``more``."""
    # frame: [kind ("map" | "seq"), path, expect_key, key, index]
    stack: list[list] = []
    nodes = 0
    said = 0
    for ev in yaml.parse(text, Loader=_FastLoader):
        if isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            stack.pop()
            continue
        if not isinstance(ev, (yaml.ScalarEvent, yaml.AliasEvent, yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            continue
        path: list = []
        if stack:
            f = stack[-1]
            if f[0] == "seq":
                path = f[1] + [f[4]]
                f[4] += 1
            elif f[2]:  # this node is a key
                f[2] = False
                f[3] = ev.value if isinstance(ev, yaml.ScalarEvent) else "?"
                path = f[1] + [f[3]]
            else:  # this node is the value of f[3]
                f[2] = True
                path = f[1] + [f[3]]
        line = ev.start_mark.line + 1
        nodes += 1
        if nodes > MAX_NODES:
            issues.append(Issue(path_str(path), f"expected at most {MAX_NODES} YAML values in a file, found more", line))
            return True
        if isinstance(ev, yaml.AliasEvent) or ev.anchor is not None:
            if said >= ALIASES_SAID:
                more.append((path_str(path), line))
            else:
                said += 1
                what = f"the alias *{ev.anchor}" if isinstance(ev, yaml.AliasEvent) else f"the anchor &{ev.anchor}"
                issues.append(Issue(path_str(path), f"expected a plain value, found {what}{_NO_ALIASES}", line))
        if isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            if len(stack) >= MAX_DEPTH:
                issues.append(Issue(path_str(path), f"expected at most {MAX_DEPTH} levels of nesting, found more", line))
                return False
            stack.append(["map" if isinstance(ev, yaml.MappingStartEvent) else "seq", path, True, None, 0])
    return False


_STR_TAG = "tag:yaml.org,2002:str"
_NULL_TAG = "tag:yaml.org,2002:null"


#: tags YAML never resolves by itself: only written out (``!!binary``: a name's text was kept
#: with the tag dropped, ``aGVsbG8=``; ``!!set``, ``!!omap``, ``!!pairs``: read as their types)
_WRITTEN_ONLY = frozenset("tag:yaml.org,2002:" + t for t in ("binary", "set", "omap", "pairs"))


def _walk_nodes(node, path, lines: dict, issues: list, key_line: int | None = None, ctor=None, keep_text=None,
                out_of_range: list | None = None) -> None:
    """Record the line of every key path; refuse duplicate keys, non-scalar keys and tags.

    Keys are compared as the values they construct to, so ``1`` and ``0x1`` (or ``yes``
    and ``true``) are duplicates too: a dict would silently merge them. A plain scalar at a
    path ``keep_text(path)`` selects is retagged as a string: it constructs to its text as written.
    Where ``out_of_range`` is a list, a number no float holds is appended to it as an issue and
    read as null in its place (see :func:`read_yaml`).
    """
    ctor = ctor if ctor is not None else _LineLoader("")
    lines[tuple(path)] = key_line if key_line is not None else node.start_mark.line + 1
    if node.tag in _WRITTEN_ONLY:  # (before a name's text is kept: the tag was dropped)
        issues.append(Issue(path_str(path), f"expected a plain YAML value, found the tag {node.tag!r} (tags are not supported)",
                            node.start_mark.line + 1))
        return
    # plain style: None from PyYAML's composer, '' from libyaml's (quoted scalars are strings already)
    if keep_text is not None and isinstance(node, yaml.ScalarNode) and not node.style \
            and node.tag not in (_STR_TAG, _NULL_TAG) and node.tag in _LineLoader.yaml_constructors and keep_text(tuple(path)):
        node.tag = _STR_TAG
    if node.tag not in _LineLoader.yaml_constructors:
        issues.append(
            Issue(path_str(path), f"expected a plain YAML value, found the tag {node.tag!r} (tags are not supported)", node.start_mark.line + 1)
        )
        return
    if out_of_range is not None and isinstance(node, yaml.ScalarNode) and node.tag in (_INT, _FLOAT):
        far = (_int_out_of_range(node.value) if node.tag == _INT else
               _float_out_of_range(node.value, yaml.SafeLoader.construct_yaml_float(ctor, node)))
        if far is not None:
            out_of_range.append(Issue(path_str(path), far, node.start_mark.line + 1))
            node.tag = _NULL_TAG
            return
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for k, v in node.value:
            kline = k.start_mark.line + 1
            if not isinstance(k, yaml.ScalarNode):
                kind = "list" if isinstance(k, yaml.SequenceNode) else "mapping"
                issues.append(Issue(path_str(path), f"expected string keys, found a {kind} used as a key", kline))
                continue
            if k.tag not in _LineLoader.yaml_constructors:
                issues.append(Issue(path_str(path), f"expected a plain YAML key, found the tag {k.tag!r} (tags are not supported)", kline))
                continue
            key = k.value if k.tag == _STR_TAG else ctor.construct_object(k)
            if key is None:  # (reported as "None: ... found unknown key None", Python's word)
                issues.append(Issue(path_str(path), "expected a key name, found null (a key written as ~ or null, "
                                                    "or left out before the colon)", kline))
                continue
            if key in seen:
                issues.append(
                    Issue(
                        path_str(path + [k.value]),
                        f"expected unique keys, found {k.value!r} again (first at line {seen[key]}); duplicate keys are never merged",
                        kline,
                    )
                )
                continue
            seen[key] = kline
            _walk_nodes(v, path + [key], lines, issues, kline, ctor, keep_text, out_of_range)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _walk_nodes(v, path + [i], lines, issues, None, ctor, keep_text, out_of_range)


def _path_at(lines: dict, line: int | None) -> str:
    """The deepest key path recorded at ``line`` ('' when none is)."""
    at = [k for k, v in lines.items() if v == line]
    return path_str(max(at, key=len)) if at else ""


def _format_in_head(head: str) -> tuple[str, str] | None:
    """The coplan format a JSON file names in its first 4096 characters (``("coplan.plan", "1")``),
    or None: what a file too big to read is, said without reading it."""
    m = re.search(r'"format"\s*:\s*"(coplan\.[a-z_]+)/(\w*)', head[:4096])
    return None if m is None else (m.group(1), m.group(2))


def _swapped(text: str, expected: str) -> list[Issue]:
    """The issue to report for a file too big to parse (over ``MAX_NODES`` values) that is
    another kind of coplan file -- a long row's plan.json given where a problem is expected --
    named from its head, as a smaller one is named once parsed; [] otherwise."""
    fmt = _format_in_head(text)
    if fmt is None or fmt[0] in expected:
        return []
    return [Issue("", f"expected {expected}, found a {fmt[0]} file (format '{fmt[0]}/{fmt[1]}', over "
                      f"{MAX_NODES} values); were the arguments swapped?", 1)]


def read_yaml(text: str, source: str | None, keep_text=None,
              expected: str = "a mapping with keys name, arms, fruits, task", out_of_range: list | None = None):
    """Parse YAML text safely; returns ``(data, lines)`` where ``lines`` maps key paths to lines.

    ``keep_text``: optional predicate on key paths (tuples) whose plain scalars are kept as
    the text written (strings), see the module docstring. ``expected``: what the file should
    hold, said when it is empty (default: a problem file). ``out_of_range``: a list to collect
    numbers no float holds (``1e400``, an integer of hundreds of digits) as issues, each read as
    null, so that a caller can say them beside the file's other mistakes; without it the first
    is refused at once."""
    lines: dict = {}
    issues: list[Issue] = []
    try:
        over = _scan_events(text, issues)
        if issues:
            raise ProblemError((_swapped(text, expected) if over else []) or issues, source)
        node = yaml.compose(text, Loader=_FastLoader)
        if node is None:
            raise ProblemError([Issue("", f"expected {expected}; found an empty file")], source)
        _walk_nodes(node, [], lines, issues, keep_text=keep_text, out_of_range=out_of_range)
        if issues:  # (with the numbers no float holds found on the way: a duplicate key hid them)
            raise ProblemError(sorted(issues + (out_of_range or []), key=lambda i: -1 if i.line is None else i.line), source)
        # keys are now known to be unique scalars, with no aliases or unknown tags
        data = _LineLoader("").construct_document(node)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        msg = getattr(e, "problem", None) or str(e)
        context = getattr(e, "context", None)
        if isinstance(e, yaml.reader.ReaderError):  # (a control character: no line, and PyYAML's "<unicode string>, position 240")
            line = text.count("\n", 0, e.position) + 1
            col = e.position - (text.rfind("\n", 0, e.position) + 1) + 1
            ch = e.character if isinstance(e.character, str) else chr(e.character)
            raise ProblemError([Issue("", f"expected printable text, found the control character "
                                                              f"U+{ord(ch):04X} at column {col}", line)], source) from None
        if "nesting depth" in str(msg):  # PyYAML >= 6.0.4 stops deep nesting itself, before the event scan can
            raise ProblemError([Issue("", f"expected at most {MAX_DEPTH} levels of nesting, found more (YAML: {msg})", line)],
                               source) from None
        if mark is not None and "cannot start any token" in str(msg) and text.splitlines()[mark.line:mark.line + 1] \
                and text.splitlines()[mark.line][mark.column:mark.column + 1] == "\t":
            raise ProblemError([Issue("", f"expected spaces for indentation, found a tab character at column {mark.column + 1} "
                                          "(YAML does not allow tabs there)", line)], source) from None
        if isinstance(e, yaml.constructor.ConstructorError) and str(msg).startswith("expected "):  # (ours: _construct_int, _construct_float)
            raise ProblemError([Issue(_path_at(lines, line), str(msg), line)], source) from None
        opened = getattr(e, "context_mark", None)
        if context and opened is not None and mark is not None and opened.line != mark.line:
            # (an unclosed bracket was reported at the line where the parser gave up -- the next key,
            # or the end of the file -- and never where it opens)
            context = f"{context} that opens at line {opened.line + 1}, column {opened.column + 1}"
        elif context and "flow node" in context and mark is not None:
            # (a bracket left open to the end of the file: PyYAML names the node it expected, there)
            unclosed = _unclosed_bracket(text, mark.index)
            if unclosed is not None:
                context = f"{context} inside the '{unclosed[0]}' that opens at line {unclosed[1]}, column {unclosed[2]}"
        raise ProblemError([Issue("", f"expected valid YAML, found a syntax error: {msg}" + (f" ({context})" if context else ""), line)], source) from None
    return data, lines


def _unclosed_bracket(text: str, index: int) -> tuple[str, int, int] | None:
    """The innermost ``[`` or ``{`` still open at character ``index`` of ``text`` (by YAML's own
    tokens, so brackets in strings and comments do not count): ``(bracket, line, column)``,
    1-based; None if none is open there."""
    stack = []
    try:
        for tok in yaml.scan(text, Loader=yaml.SafeLoader):
            if tok.start_mark.index >= index:
                break
            if isinstance(tok, (yaml.FlowSequenceStartToken, yaml.FlowMappingStartToken)):
                stack.append(tok)
            elif isinstance(tok, (yaml.FlowSequenceEndToken, yaml.FlowMappingEndToken)) and stack:
                stack.pop()
    except yaml.YAMLError:
        pass
    if not stack:
        return None
    tok = stack[-1]
    return ("[" if isinstance(tok, yaml.FlowSequenceStartToken) else "{"), tok.start_mark.line + 1, tok.start_mark.column + 1


def line_of(lines: dict, loc) -> int | None:
    """The line of key path ``loc`` in ``lines`` (from :func:`read_yaml`), or of its nearest
    recorded ancestor; None when not even the document has one."""
    loc = tuple(loc)
    while loc:
        if loc in lines:
            return lines[loc]
        # (a key that is no string -- `1:` in a mapping -- is named by its text: its line, not its parent's)
        named = None if all(not isinstance(x, str) or x.isidentifier() for x in loc) else next(
            (n for k, n in lines.items() if len(k) == len(loc) and tuple(map(str, k)) == tuple(map(str, loc))), None)
        if named is not None:
            return named
        loc = loc[:-1]
    return lines.get(())


def read_input_text(path, error: type[InputError]) -> str:
    """The UTF-8 text of an input file, or ``error`` (a :class:`~coplan.errors.InputError`
    subclass) saying why not: missing, a directory, over ``MAX_FILE_BYTES``, unreadable, not
    UTF-8 (with the line of the first bad byte)."""
    p = Path(path)
    src = str(p)
    if not p.exists():
        raise error([Issue("", "expected an existing YAML file, found no file at this path")], src)
    if p.is_dir():
        raise error([Issue("", "expected a YAML file, found a directory")], src)
    kind = special_file(p)  # (a device would be read for ever)
    if kind is not None:
        raise error([Issue("", f"expected a YAML file, found {kind}")], src)
    size = p.stat().st_size
    if size > MAX_FILE_BYTES:
        with p.open("rb") as fh:  # (a plan of a long row is over the cap: say what it is, as for a small one)
            other = _format_in_head(fh.read(4096).decode("utf-8", "replace"))
        found = other[0] if other is not None else None
        expected = error.__name__.lower().removesuffix("error")  # (FeedError: a coplan.feed is the kind asked for)
        if found is not None and found.removeprefix("coplan.") != expected:
            raise error([Issue("", f"expected a YAML file, found a {found} file of {size} bytes; were the "
                                   f"arguments swapped?")], src)
        raise error([Issue("", f"expected a file of at most {MAX_FILE_BYTES} bytes, found {size} bytes")], src)
    try:
        with open(p, "rb") as f:  # (at most the cap, whatever the size said: a pipe says 0)
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        err = error([Issue("", f"expected a readable file, found an error: {e.strerror}")], src)
        err.unreadable = True
        raise err from None
    if len(raw) > MAX_FILE_BYTES:
        raise error([Issue("", f"expected a file of at most {MAX_FILE_BYTES} bytes, found more")], src)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise error([Issue("", f"expected UTF-8 text, found the undecodable byte 0x{raw[e.start]:02x} at offset {e.start}", line)],
                    src) from None


#: a key's common other names, by the word of coplan's key they stand for (``gantry.speed`` is
#: ``gantry.max_velocity``: spelling alone suggested ``settle``)
_SYNONYMS = {"speed": "velocity", "vel": "velocity", "accel": "acceleration", "acc": "acceleration"}


def did_you_mean(key: Any, choices) -> str:
    """``"; did you mean 'x'?"`` for :func:`nearest_name` of an unknown ``key``, or ``""``."""
    near = nearest_name(key, choices)
    return f"; did you mean {near!r}?" if near is not None else ""


def nearest_name(key: Any, choices) -> str | None:
    """The closest of ``choices`` to an unknown ``key``, or None: the one choice with the key (or
    its synonym) as a whole word (``max_velocity`` for ``speed`` or ``velocity``) unless a
    spelling is very close, else the closest spelling."""
    names = [str(c) for c in choices]
    near = difflib.get_close_matches(str(key), names, n=1, cutoff=0.8)  # a slip of spelling first ('stop' for 'stops')
    if near:
        return near[0]
    word = str(key).strip().lower()
    word = _SYNONYMS.get(word, word)
    # each word of the key by the word coplan uses for it, a slip of spelling in it forgiven
    # ('max_speed', 'max_sped' -> 'max_velocity'; spelling alone suggested 'max_jerk')
    said = "_".join(_SYNONYMS[m[0]] if (m := difflib.get_close_matches(w, list(_SYNONYMS), n=1, cutoff=0.75)) else w
                    for w in word.split("_"))
    if said != word and said in names:
        return said
    whole = [c for c in names if word in c.lower().split("_")]
    if len(whole) == 1:
        return whole[0]
    m = difflib.get_close_matches(str(key), names, n=1, cutoff=0.5)
    return m[0] if m else None
