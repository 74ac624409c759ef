"""Filling a worldfile template for one run: ``{{name}}`` placeholders and model property
overrides, both done on the text so the resolved worldfile each run used can be kept beside
its results and loaded again by ``stage`` or ``player``.

Placeholders are ``{{name}}`` (spaces allowed inside the braces, ``name`` a Python-style
identifier), anywhere but in ``#`` comments (which are left as written, so a template can
document its placeholders). Braces have no meaning in Stage's worldfile language, so a
placeholder cannot be mistaken for worldfile text; any other ``{{`` outside comments is
refused rather than left in the file.

Overrides (``"r0.pose" = [1, 2, 0, 90]``) set a property of the model whose worldfile entity
says ``name "r0"``: the property is appended inside that entity, on the line of its closing
parenthesis, and a worldfile's later property replaces an earlier one of the same name. Line
numbers therefore stay those of the template (an error message's line is the template's).
"""

import fnmatch
import re
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

PLACEHOLDER = re.compile(r"\{\{\s*([A-Za-z_][A-Za-z0-9_]*)\s*\}\}")


class TemplateError(ValueError):
    """A template or override that cannot be applied; ``line`` is the template's line when
    the error has one (0 otherwise)."""

    def __init__(self, msg: str, line: int = 0):
        super().__init__(msg)
        self.line = line


def line_of(text: str, offset: int) -> int:
    """The 1-based line of ``offset`` in ``text``."""
    return text.count("\n", 0, offset) + 1


_CODE_OR_COMMENT = re.compile(r'("[^"\n]*")|(#[^\n]*)|([^"#]+|")')


def _code_spans(text: str) -> List[Tuple[int, int]]:
    """The spans of ``text`` outside ``#`` comments (strings included: a ``#`` in a string
    does not start a comment)."""
    spans: List[Tuple[int, int]] = []
    for m in _CODE_OR_COMMENT.finditer(text):
        if m.group(2) is None:
            if spans and spans[-1][1] == m.start():
                spans[-1] = (spans[-1][0], m.end())
            else:
                spans.append(m.span())
    return spans


def _placeholder_matches(text: str) -> List["re.Match"]:
    return [m for s, e in _code_spans(text) for m in PLACEHOLDER.finditer(text, s, e)]


def placeholders(text: str) -> Dict[str, int]:
    """Every placeholder name of ``text`` (outside comments) with the line of its first use;
    a ``{{`` or ``}}`` outside comments that is not part of a placeholder raises, naming its
    line."""
    found: Dict[str, int] = {}
    matches = _placeholder_matches(text)
    for m in matches:
        found.setdefault(m.group(1), line_of(text, m.start()))
    taken = [m.span() for m in matches]
    for bad in ("{{", "}}"):
        line = 0
        for s, e in _code_spans(text):
            at = text.find(bad, s, e)
            while at >= 0 and any(a <= at < b for a, b in taken):
                at = text.find(bad, at + 1, e)
            if at >= 0:
                line = line_of(text, at)
                break
        if line:
            raise TemplateError(
                f"`{bad}` that is not part of a {{{{name}}}} placeholder "
                "(names are letters, digits and _, not starting with a digit)",
                line,
            )
    return found


def format_value(value, quote_strings: bool) -> str:
    """A plan value as worldfile text: numbers as Python prints them (shortest exact form),
    booleans 1/0, strings as they are (a placeholder) or quoted (an override), lists as
    space-separated values (a placeholder) or a ``[ ... ]`` tuple (an override)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        if not quote_strings:
            return value
        if '"' in value or "\n" in value:
            raise TemplateError(f"string {value!r}: a worldfile string cannot hold `\"` or a newline")
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        inner = " ".join(format_value(v, True) for v in value)
        return f"[ {inner} ]" if quote_strings else inner
    raise TemplateError(f"{value!r}: not a number, string, boolean or list")


def fill(text: str, values: Dict[str, object]) -> str:
    """``text`` with every placeholder replaced by its value; a placeholder without one
    raises, naming it and its line."""

    def sub(m: "re.Match") -> str:
        name = m.group(1)
        if name not in values:
            raise TemplateError(f"placeholder {{{{{name}}}}} has no value", line_of(text, m.start()))
        return format_value(values[name], quote_strings=False)

    out, last = [], 0
    for m in _placeholder_matches(text):
        out.append(text[last:m.start()])
        out.append(sub(m))
        last = m.end()
    out.append(text[last:])
    return "".join(out)


@dataclass
class Entity:
    """A parenthesised worldfile entity with an explicit ``name "..."``."""

    name: str
    close: int  # offset of its closing parenthesis
    line: int


_TOKEN = re.compile(r'#[^\n]*|"[^"\n]*"|[()\[\]]|[^\s()\[\]#"]+')


def named_entities(text: str) -> List[Entity]:
    """The entities of ``text`` that give themselves a ``name``, in the order they close
    (``define`` bodies excluded: they are macros, not models)."""
    defines: List[bool] = []  # per open entity: whether it is a define's body
    names: List[Optional[Entity]] = []  # per open entity: its name, once seen
    out: List[Entity] = []
    prev: List[str] = []  # the last three tokens
    bracket = 0
    for m in _TOKEN.finditer(text):
        tok = m.group(0)
        if tok.startswith("#"):
            continue
        if tok == "[":
            bracket += 1
        elif tok == "]":
            bracket = max(0, bracket - 1)
        elif tok == "(":
            # `define NAME PARENT (` opens a macro body
            defines.append(len(prev) == 3 and prev[0] == "define")
            names.append(None)
        elif tok == ")":
            if defines:
                is_define = defines.pop()
                ent = names.pop()
                if ent is not None and not is_define:
                    ent.close = m.start()
                    out.append(ent)
        elif tok.startswith('"'):
            if prev and prev[-1] == "name" and names and bracket == 0 and names[-1] is None:
                names[-1] = Entity(tok[1:-1], -1, line_of(text, m.start()))
        prev.append(tok)
        if len(prev) > 3:
            del prev[0]
    return out


def set_properties(text: str, overrides: Sequence[Tuple[str, str, object]]) -> str:
    """``text`` with each ``(model, property, value)`` set: appended inside the last entity
    named ``model`` (the one Stage's name lookup finds)."""
    if not overrides:
        return text
    entities = {e.name: e for e in named_entities(text)}
    inserts: Dict[int, List[str]] = {}
    for model, prop, value in overrides:
        ent = entities.get(model)
        if ent is None:
            known = ", ".join(sorted(entities)[:12]) or "none"
            raise TemplateError(
                f"no model with `name \"{model}\"` in the worldfile to set `{prop}` on "
                f"(overrides apply to models named in the plan's world file itself; named: {known})"
            )
        inserts.setdefault(ent.close, []).append(f" {prop} {format_value(value, True)} ")
    out = []
    last = 0
    for at in sorted(inserts):
        out.append(text[last:at])
        out.extend(inserts[at])
        last = at
    out.append(text[last:])
    return "".join(out)


def glob_models(text: str, pattern: str) -> List[str]:
    """The explicitly named models of ``text`` whose names match the glob ``pattern``."""
    seen = []
    for e in named_entities(text):
        if fnmatch.fnmatchcase(e.name, pattern) and e.name not in seen:
            seen.append(e.name)
    return seen
