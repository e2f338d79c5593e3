"""The batch rows' float I/O on bytes: ``librt.strings`` (compiled inline by mypyc) and the
plain-Python stand-in ``motionplc.planning._f64io`` for an installation without librt.

* The stand-in writes and reads the same bytes as librt (signed zeros, infinities, NaN
  payloads, subnormals), truncates alike and refuses a read past the end alike.
* Without librt (its import blocked in a subprocess) the core runs as plain Python with the
  stand-in, says why, and ``plan_batch``'s numpy path (core rows through ``plan_rows``)
  still equals :func:`plan` bit for bit.
"""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motionplc.planning import _f64io

ROOT = Path(__file__).resolve().parents[2]
librt_strings = pytest.importorskip("librt.strings", reason="librt is not installed")


def _values() -> list[float]:
    rng = np.random.default_rng(64)
    special = [0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, -5e-324, 2.2250738585072014e-308]
    special += [1.7976931348623157e308, 1.0, -1.0, 1 / 3]
    bits = rng.integers(0, 2**64, size=2000, dtype=np.uint64)
    return special + np.frombuffer(bits.tobytes(), dtype="<f8").tolist()


def test_stand_in_writes_and_reads_the_bytes_librt_does() -> None:
    values = _values()
    ours = _f64io.BytesWriter()
    theirs = librt_strings.BytesWriter()
    for x in values:
        _f64io.write_f64_le(ours, x)
        librt_strings.write_f64_le(theirs, x)
    data = ours.getvalue()
    assert data == theirs.getvalue() == struct.pack(f"<{len(values)}d", *values)
    assert len(ours) == len(theirs) == 8 * len(values)
    for k in range(len(values)):
        a = _f64io.read_f64_le(data, 8 * k)
        b = librt_strings.read_f64_le(data, 8 * k)
        assert struct.pack("<d", a) == struct.pack("<d", b) == data[8 * k : 8 * k + 8]
    for k in (3, 5, len(data) - 8):  # unaligned offsets read the bytes there
        a = _f64io.read_f64_le(data, k)
        b = librt_strings.read_f64_le(data, k)
        assert struct.pack("<d", a) == struct.pack("<d", b) == data[k : k + 8]
    for w in (ours, theirs):
        w.truncate(16)
        assert len(w) == 16
    assert ours.getvalue() == theirs.getvalue() == data[:16]


@pytest.mark.parametrize(
    ("index", "error"), [(-1, ValueError), (9, IndexError), (10, IndexError), (100, IndexError)]
)
def test_stand_in_refuses_a_read_past_the_end_like_librt(index: int, error: type) -> None:
    data = struct.pack("<2d", 1.0, 2.0)
    for read in (_f64io.read_f64_le, librt_strings.read_f64_le):
        with pytest.raises(error):
            read(data, index)


@pytest.mark.parametrize("size", [-1, 17])
def test_stand_in_refuses_a_bad_truncation_like_librt(size: int) -> None:
    for mod in (_f64io, librt_strings):
        w = mod.BytesWriter()
        mod.write_f64_le(w, 1.0)
        mod.write_f64_le(w, 2.0)
        with pytest.raises(ValueError):
            w.truncate(size)
        assert len(w) == 16


_WITHOUT_LIBRT = r"""
import json, sys
sys.modules["librt"] = None  # as if librt were not installed
sys.path.insert(0, sys.argv[1])
import motionplc
from motionplc.planning import _batchrow, plan, plan_batch
from tests.planning._cases import generate_cases
from tests.planning.test_batch import _columns, _row_equals_plan

cases = generate_cases(300, 2024, outside_fraction=0.2, asymmetric_fraction=0.3)
b = plan_batch(*_columns(cases))
refs = [plan(c.start(), c.target(), c.limits()) for c in cases]
bad = [i for i, ref in enumerate(refs) if _row_equals_plan(b, i, ref)]
print(json.dumps({
    "status": list(motionplc.compiled_core()),
    "writer": _batchrow.BytesWriter.__module__,
    "rows": len(b), "width": int(b.t.shape[1]), "bad": bad,
}))
"""


def test_without_librt_the_pure_core_plans_batches_with_the_stand_in() -> None:
    env = {k: v for k, v in os.environ.items() if k != "MOTIONPLC_PURE_PYTHON"}
    res = subprocess.run(
        [sys.executable, "-c", _WITHOUT_LIBRT, str(ROOT)],
        env=env,
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    compiled, reason = out["status"]
    assert compiled is False and "librt" in reason, reason
    assert out["writer"] == "motionplc.planning._f64io"
    assert out["rows"] == 300 and out["width"] > 7  # core rows only, some wider than 7
    assert out["bad"] == []
