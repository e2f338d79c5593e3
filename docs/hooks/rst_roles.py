"""A griffe extension for the API pages (mkdocs.yml): the docstrings' Sphinx roles as code.

The docstrings write cross-references the reST way (:func:`plan`, :class:`~a.b.Path`,
``Public API::``); Markdown would print the role names. This rewrites each role to its target
as inline code (``~a.b.Path`` -> ``Path``, the last component, as Sphinx shows it) and a
paragraph's closing ``::`` to ``:`` (the indented block after it is code in Markdown too).
"""

from __future__ import annotations

import re
from typing import Any

from griffe import Extension, Object

ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|exc|obj|const|ref):`(~?)([^`]+)`")
LITERAL_BLOCK = re.compile(r"(\S)::$", re.MULTILINE)


def markdown_roles(text: str) -> str:
    """``text`` with its reST roles as inline code and its ``::`` paragraph ends as ``:``."""

    def code(m: re.Match[str]) -> str:
        target = m.group(2).strip()
        if m.group(1):  # ~a.b.c shows c
            target = target.rsplit(".", 1)[-1]
        return f"`{target}`"

    return LITERAL_BLOCK.sub(r"\1:", ROLE.sub(code, text))


class RstRoles(Extension):
    """Rewrites every loaded object's docstring with :func:`markdown_roles`."""

    def on_instance(self, *, obj: Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown_roles(obj.docstring.value)
