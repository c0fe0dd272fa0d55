"""The automation plant from Python (``Session.plant_command``, docs/python.md): a live ECLSS
plant (``robosim automation``) on a real session; a fault injected from Python rings its alarm;
the planner isolates the faulty unit and brings its spare on line with transactions it sees
come back through ``wait_changes``; the plant follows the committed model and stops ringing."""

import pytest

import robosim


def wait_plant(s, what, pred, procs, timeout=30.0):
    """Polls the plant's state until ``pred`` holds (the plant follows commits on its own
    loop); the state."""
    import time

    start = time.monotonic()
    while True:
        st = s.plant_command({"cmd": "get"})
        if pred(st):
            return st
        if time.monotonic() - start > timeout:
            raise AssertionError(f"{what} within {timeout} s; the plant says {st}\n{procs.logs()}")
        time.sleep(0.02)


def test_plant_command_without_a_plant_raises_a_session_error(procs):
    procs.start_keeper()
    s = procs.attach()
    with pytest.raises(robosim.SessionError) as e:
        s.plant_command({"cmd": "fault", "fault": "sorbent_bed_failure"})
    assert e.value.kind == "session"
    assert "no automation plant runs in session" in e.value.message
    assert "robosim automation" in e.value.message, "it says how to start one"


def test_a_fault_injected_from_python_rings_and_a_planner_isolates_and_replaces_the_unit(procs):
    procs.start_keeper()
    procs.start_plant()
    s = procs.attach()
    objects = s.snapshot().objects()
    for name in ["eclss", "eclss_spares", "eclss_isolated", "co2_sorbent_bed", "co2_sorbent_bed_spare"]:
        assert name in objects, f"the plant's unit {name} is in the session"
    before = s.plant_command({"cmd": "get"})
    assert before["alarms"] == [] and before["faults"] == []
    assert "co2_sorbent_bed" in before["online"]

    st = s.plant_command({"cmd": "fault", "fault": "sorbent_bed_failure"})
    assert st["alarms"][0]["alarm"] == "A_co2_bed", "the fault's own alarm rings at once"
    assert st["faults"][0]["components"] == ["co2_sorbent_bed"]
    assert st["faults"][0]["contained"] is False
    # A refused command raises and injects nothing.
    for bad in ["no_such_fault", "co2_not_removed"]:
        with pytest.raises(robosim.SessionError) as e:
            s.plant_command({"cmd": "fault", "fault": bad})
        assert "refused" in e.value.message
    with pytest.raises(robosim.SessionError):
        s.plant_command({"cmd": "vent"})
    assert len(s.plant_command({"cmd": "get"})["faults"]) == 1
    # The alarm is still ringing when asked again: it is the plant's state, not a reply's.
    assert [a["alarm"] for a in s.plant_command({"cmd": "get"})["alarms"]][0] == "A_co2_bed"

    # The planner handles the alarm: isolate the unit, then bring the spare on line — two
    # transactions, each seen coming back as a change of the session.
    while s.wait_change(timeout=0.2) is not None:
        pass
    v = s.transact([["attach", "co2_sorbent_bed", "eclss_isolated"]])
    changes = s.wait_changes(timeout=10.0)
    assert changes is not None and changes[-1]["version"] == v
    assert "co2_sorbent_bed" in changes[-1]["objects"]
    st = wait_plant(s, "the plant to see the isolation", lambda st: st["faults"][0]["contained"], procs)
    assert st["isolated"] == ["co2_sorbent_bed"]
    assert st["faults"][0]["repaired"] is False
    assert st["alarms"], "contained but not repaired: its alarms still ring"
    w = s.transact([["attach", "co2_sorbent_bed_spare", "eclss"]])
    assert w == v + 1
    assert s.wait_change(timeout=10.0) == w
    st = wait_plant(s, "the plant to see the spare on line", lambda st: st["faults"][0]["repaired"], procs)
    assert st["alarms"] == [], "a repaired fault rings no alarm"
    assert "co2_sorbent_bed_spare" in st["spares_online"]
    assert s.snapshot().version == w
