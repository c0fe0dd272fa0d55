"""Dataflow graphs from Python (``Session.dataflow``, docs/dataflow.md): a graph file run pass
by pass on a real session — a proportional servo on the positioner's first joint converges as
its closed form says, each pass one transaction seen in the session; a reload keeps the
unchanged actors; a graph with an error names its file and line."""

import os

import pytest

import robosim

SERVO = """\
rate 10
source q   = joint positioner 0
source ref = const {ref}
data e
data step
data qn
actor err  = sub(ref, q) -> e
actor gain = gain(e) -> step k={k}
actor next = add(q, step) -> qn
sink qn -> joint positioner 0
"""


def write(procs, name, text):
    path = os.path.join(procs.home, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def test_a_servo_graph_converges_as_its_closed_form_and_reloads(procs):
    procs.start_keeper()
    s = procs.attach()
    q0 = float(s.joints("positioner")[0])
    ref = q0 + 0.2
    path = write(procs, "servo.flow", SERVO.format(ref=repr(ref), k=0.5))
    df = s.dataflow(path)
    assert isinstance(df, robosim.Dataflow)
    for n in range(1, 6):
        v0 = s.version
        r = df.step()
        assert len(r["versions"]) == 1 and r["versions"][0] > v0, "one transaction per pass"
        want = ref + (q0 - ref) * 0.5**n
        assert abs(float(s.joints("positioner")[0]) - want) < 1e-12
        assert abs(df.value("qn") - want) < 1e-12
    st = df.state()
    assert st["passes"] == 5 and st["writes"] == 5
    assert {a["name"]: a["fired"] for a in st["actors"]} == {"err": 5, "gain": 5, "next": 5}

    # The gain halves: only that actor is replaced.
    write(procs, "servo.flow", SERVO.format(ref=repr(ref), k=0.25))
    r = df.reload()
    assert r == {"kept": ["err", "next"], "replaced": ["gain"], "added": [], "removed": []}
    q5 = float(s.joints("positioner")[0])
    df.step()
    assert abs(float(s.joints("positioner")[0]) - (q5 + 0.25 * (ref - q5))) < 1e-12
    # The kept actors went on counting; the new one starts at one firing.
    fired = {a["name"]: a["fired"] for a in df.state()["actors"]}
    assert fired == {"err": 6, "gain": 1, "next": 6}


def test_a_graph_with_an_error_names_its_file_and_line(procs):
    procs.start_keeper()
    s = procs.attach()
    path = write(procs, "bad.flow", "source q = joint positioner 0\ndata y\nactor a = gain(q) -> y\n")
    with pytest.raises(robosim.RequestError) as e:
        s.dataflow(path)
    assert f"{path}:3:" in e.value.message and "needs the parameter k=" in e.value.message
