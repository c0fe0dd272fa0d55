"""robosim.plot draws a run's signal log and says what it drew (the same as `robosim plot`)."""

import os

import pytest

import robosim


def test_a_signal_log_is_drawn_and_described(tmp_path):
    log = tmp_path / "simulator-arm.csv"
    rows = ["t_s,q1_rad,q2_rad,qd1_rad_s,qd2_rad_s,tau1_Nm,tau2_Nm"]
    for k in range(1, 101):
        t = k * 0.01
        rows.append(f"{t},{t},{-2 * t},1,-2,3,0.5")
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "plots"
    j = robosim.plot(log, out)
    fig = j["figures"][0]
    assert fig["file"] == "arm.png"
    assert [p["title"] for p in fig["panels"]] == [
        "joint positions",
        "joint velocities",
        "joint efforts",
        "actuator work",
    ]
    q = fig["panels"][0]
    assert q["series"] == ["joint 1", "joint 2"]
    assert q["x_range"] == pytest.approx([0.01, 1.0])
    assert q["y_range"] == pytest.approx([-2.0, 1.0])
    # Power 1·3 + (−2)·0.5 = 2 W from t = 0.01 to 1 s.
    assert fig["panels"][3]["y_range"] == pytest.approx([0.0, 2 * 0.99])
    with open(out / "arm.png", "rb") as f:
        assert f.read(4)[1:] == b"PNG"


def test_a_file_that_is_no_run_is_refused_by_name(tmp_path):
    bad = tmp_path / "notes.csv"
    bad.write_text("time,value\n0,1\n")
    with pytest.raises(robosim.RobosimError) as e:
        robosim.plot(bad, tmp_path / "out")
    assert "notes.csv" in str(e.value) and "t_s" in str(e.value)
    assert not os.path.exists(tmp_path / "out" / "plot.json")
