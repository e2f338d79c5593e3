"""mkdocs hook (mkdocs.yml): nav entries of pages that another generator may not have written
yet are dropped while their file is missing, so the strict build stays green until they land.

``OPTIONAL``: the G-code reference page (``docs/reference/gcode.md``, generated from the
G-code interpreter's word table). Every other nav entry must exist (strict mode).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

OPTIONAL = ("reference/gcode.md",)


def _prune(items: list[Any], docs: Path) -> list[Any]:
    out = []
    for item in items:
        if isinstance(item, dict):
            ((title, value),) = item.items()
            if isinstance(value, list):
                out.append({title: _prune(value, docs)})
            elif value in OPTIONAL and not (docs / value).is_file():
                continue
            else:
                out.append(item)
        elif isinstance(item, str) and item in OPTIONAL and not (docs / item).is_file():
            continue
        else:
            out.append(item)
    return out


def on_config(config: Any, **kwargs: Any) -> Any:
    if config.nav:
        config.nav = _prune(config.nav, Path(config.docs_dir))
    return config
