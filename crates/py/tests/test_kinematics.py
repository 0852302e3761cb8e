import math

import pytest

import fs020n

HOME = [0, 0, -90, 0, -90, 0]


def test_fk_of_home_is_the_documented_flange_pose():
    x, y, z, o, a, t = fs020n.fk(HOME)
    assert (x, y, z) == pytest.approx((850.0, 0.0, 1153.5), abs=1e-9)
    assert (o, a, t) == pytest.approx((0.0, 180.0, 0.0), abs=1e-9)
    assert fs020n.HOME == [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]


def test_ik_inverts_fk_nearest_first():
    q = [10.0, 5.0, -85.0, 3.0, -80.0, 2.0]
    pose = fs020n.fk(q)
    sols = fs020n.ik(pose, near=q)
    assert len(sols) >= 2  # several arm configurations reach a pose
    assert max(abs(a - b) for a, b in zip(sols[0], q)) < 1e-6
    for s in sols:
        assert fs020n.fk(s) == pytest.approx(pose, abs=1e-6)
    limits = fs020n.joint_limits()
    assert len(limits) == 6
    for s in sols:
        assert all(lo <= v <= hi for v, (lo, hi) in zip(s, limits))


def test_ik_of_an_unreachable_pose_is_empty_and_bad_input_is_refused():
    assert fs020n.ik((5000, 0, 0, 0, 180, 0)) == []
    with pytest.raises(fs020n.LimitError):
        fs020n.ik((math.nan, 0, 1000, 0, 180, 0))
    with pytest.raises(fs020n.LimitError) as e:
        fs020n.fk([0, 0, math.inf, 0, -90, 0])
    assert isinstance(e.value, ValueError)
    with pytest.raises(ValueError, match="6 values"):
        fs020n.fk([0, 0, -90])
    with pytest.raises(ValueError, match=r"joints\[2\] must be a number"):
        fs020n.fk([0, 0, "x", 0, 0, 0])


def test_numpy_arrays_and_other_iterables_are_accepted():
    np = pytest.importorskip("numpy")
    ref = fs020n.fk(HOME)
    assert fs020n.fk(np.array(HOME, dtype=float)) == ref
    assert fs020n.fk(np.array(HOME, dtype=np.int32)) == ref
    assert fs020n.fk(tuple(HOME)) == ref
    assert fs020n.fk(v for v in HOME) == ref
    sols = fs020n.ik(np.array(ref), near=np.array(HOME))
    assert sols[0] == pytest.approx(HOME, abs=1e-9)
