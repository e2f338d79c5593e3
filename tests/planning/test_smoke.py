import math

from motionplc.planning import Limits, State, plan


def test_doc_example_reaches_target() -> None:
    prof = plan(State(0.0, 0.0, 0.0), State(6.0), Limits(v_max=1.8, a_max=1.2, j_max=1.0))
    end = prof.end
    assert math.isclose(end.p, 6.0, abs_tol=1e-9)
    assert abs(end.v) < 1e-9 and abs(end.a) < 1e-10
    # cruise reached: 2 * (1.2 + 0.3 + 1.2) + (6 - 2 * 2.43) / 1.8
    assert math.isclose(prof.duration, 5.4 + (6.0 - 4.86) / 1.8, rel_tol=1e-12)
