"""Griffe extension for the API reference: Sphinx cross-reference roles in docstrings become code spans.

The package's docstrings name other objects with Sphinx roles (``:func:`load_robot```,
``:class:`~placement.planning.StepResult```, ``:mod:`.transfer```). mkdocstrings renders Markdown, where
such a role would stay as literal text (":func:" before a code span). This extension rewrites each role,
in the parsed docstring, into an autorefs marker around a code span:

* the target is resolved in the scope of the object the docstring belongs to (its members, its
  module's names and imports, then the parents'), so ``Robot.full_q`` or ``:meth:`update``` in a
  method's docstring name the full path; a leading ``.`` is relative to the docstring's package;
* the marker is *optional*: autorefs links it to the object's anchor when some API page documents
  that object, and leaves the plain code span (no warning) otherwise;
* a ``~`` prefix shows only the last component, as in Sphinx.

Only prose is rewritten (text sections and the descriptions of parameters, attributes, returns,
raises, admonitions); names, types and example code are left as they are. Registered in mkdocs.yml
under the python handler's ``extensions``; tests/test_docs.py checks that no role text is left in the
built API pages and that roles became links.
"""

from __future__ import annotations

import html
import re
from functools import cached_property
from typing import Any

from griffe import (
    Docstring,
    DocstringElement,
    DocstringSection,
    DocstringSectionKind,
    Extension,
    Module,
    NameResolutionError,
    Object,
)

#: ``:role:`target``` for the Python-domain roles the docstrings use (``:py:func:`` too).
ROLE = re.compile(r":(?:py:)?(?:func|class|mod|data|attr|meth|exc|obj|const|type):`(?P<target>[^`\s]+)`")


def resolve(obj: Object, target: str) -> str | None:
    """The full dotted path ``target`` names in ``obj``'s docstring, or None when nothing in scope has
    that name (then the role renders as plain code)."""
    if target.startswith("."):
        # relative module, as in an import statement: one dot is the docstring's own package
        module = obj if isinstance(obj, Module) else obj.module
        package = module.path if module.is_init_module else module.path.rpartition(".")[0]
        level = len(target) - len(target.lstrip("."))
        for _ in range(level - 1):
            package = package.rpartition(".")[0]
        return f"{package}.{target.lstrip('.')}"
    head, _, rest = target.partition(".")
    try:
        base = obj.resolve(head)
    except NameResolutionError:
        # a dotted path from the top-level package (placement.x.y) that the scope does not import
        return target if rest and head == obj.package.name else None
    return f"{base}.{rest}" if rest else base


def code_span(obj: Object, match: re.Match[str]) -> str:
    """The replacement of one role: an optional autoref around ``<code>shown</code>``, or a plain
    code span when the name does not resolve."""
    target = match["target"].lstrip("~")
    shown = target.rpartition(".")[2] if match["target"].startswith("~") else target
    path = resolve(obj, target)
    if path is None:
        return f"`{shown}`"
    return f'<autoref identifier="{html.escape(path)}" optional><code>{html.escape(shown)}</code></autoref>'


def rewrite(obj: Object, text: str) -> str:
    """``text`` from ``obj``'s docstring with every role replaced by :func:`code_span`."""
    return ROLE.sub(lambda m: code_span(obj, m), text) if ":" in text else text


class RolesDocstring(Docstring):
    """A docstring whose parsed sections have their roles rewritten.

    The parsed sections are rewritten, not the raw text: a role's colons take part in how the Google
    parser splits ``name: description`` lines, so rewriting the raw text could change what a docstring
    parses into. Parsing stays lazy (on first use, as for any docstring), so docstrings no page shows
    are never parsed and never warn."""

    @cached_property
    def parsed(self) -> list[DocstringSection]:
        sections = self.parse()
        obj = self.parent
        if obj is None:
            return sections
        for section in sections:
            if isinstance(section.value, str):
                section.value = rewrite(obj, section.value)
            elif isinstance(section.value, DocstringElement):  # an admonition
                section.value.description = rewrite(obj, section.value.description)
            elif isinstance(section.value, list):
                for i, item in enumerate(section.value):
                    if isinstance(item, DocstringElement):
                        item.description = rewrite(obj, item.description)
                    elif isinstance(item, tuple) and item[0] is DocstringSectionKind.text:  # examples' prose
                        section.value[i] = (item[0], rewrite(obj, item[1]))
        return sections


class SphinxRoles(Extension):
    """Gives every docstring of a package that holds a role the rewriting :class:`RolesDocstring`,
    once the whole package is loaded (so that names imported from sibling modules resolve)."""

    def on_package(self, *, pkg: Module, **kwargs: Any) -> None:
        self._swap(pkg, set())

    def _swap(self, obj: Object, seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        d = obj.docstring
        if d is not None and not isinstance(d, RolesDocstring) and ROLE.search(d.value):
            obj.docstring = RolesDocstring(
                d.value,
                lineno=d.lineno,
                endlineno=d.endlineno,
                parent=obj,
                parser=d.parser,
                parser_options=d.parser_options,
            )
        for member in obj.members.values():
            if not member.is_alias:  # an imported name's docstring is its module's, swapped there
                self._swap(member, seen)  # type: ignore[arg-type]
