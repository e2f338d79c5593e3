"""Regenerate docs/ from motionplc.schema: the reference pages and the JSON Schema files.

    .venv/bin/python tools/gen_docs.py           # write docs/reference/*.md, docs/schema/*.json
    .venv/bin/python tools/gen_docs.py --check   # exit 1 listing the files that are stale

tests/schema/test_docs.py fails when docs/ differs from what this produces.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from motionplc.schema import KINDS, json_schema, reference_markdown
from motionplc.schema.render import dumps

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def generated() -> dict[Path, str]:
    """Every generated file (path under the repository root -> its text)."""
    out: dict[Path, str] = {}
    from motionplc.gcode import reference_markdown as gcode_reference

    for kind in KINDS:
        out[Path("docs/reference") / f"{kind}.md"] = reference_markdown(kind)
        out[Path("docs/schema") / f"{kind}.schema.json"] = dumps(json_schema(kind))
    out[Path("docs/reference") / "gcode.md"] = gcode_reference()
    from motionplc.schema.campaign import CAMPAIGN  # scenario campaigns (motionplc campaign)
    from motionplc.schema.render import to_json_schema, to_markdown

    out[Path("docs/reference") / "campaign.md"] = to_markdown(CAMPAIGN)
    out[Path("docs/schema") / "campaign.schema.json"] = dumps(to_json_schema(CAMPAIGN))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only report stale files")
    args = ap.parse_args(argv)
    stale = []
    for rel, text in generated().items():
        path = ROOT / rel
        current = path.read_text(encoding="utf-8") if path.is_file() else None
        if current == text:
            continue
        stale.append(str(rel))
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    for rel in stale:
        print(("stale: " if args.check else "wrote: ") + rel)  # noqa: T201
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
