"""The actuator description: the shipped default is the paper's SEA; bad files are refused by field."""

from __future__ import annotations

import tomllib
from importlib import resources

import pytest

from seagen.actuator import ActuatorError, actuator_from_dict, default_actuator, load_actuator
from seagen.geometry import geometry
from tests.conftest import EXAMPLE_ACTUATOR


def _paper() -> dict:
    """The shipped default description as parsed TOML (a fresh copy)."""
    return tomllib.loads(resources.files("seagen.actuators").joinpath("paper.toml").read_text())


def test_default_is_the_papers_actuator():
    """The default file gives the paper's numbers (Eq. 3-6, §IV-A) exactly as the geometry uses them."""
    a = default_actuator()
    assert a.mm_per_count == 20.0 / (380.0 * 12.0)
    assert round(a.mm_per_count, 8) == 0.00438596
    assert round(a.pot_deg_per_count, 6) == 0.012969
    assert a.adc_max == 4095 and a.stiffness_n_per_mm == 4.2 and a.motor.no_load_rpm == 32300.0
    g = geometry()
    assert a == g.actuator and a.mm_per_count == g.mm_per_count and a.adc_max == g.adc_max


def test_digest_follows_values_not_formatting(tmp_path):
    """Two files with the same values have one digest; a changed value changes it."""
    src = resources.files("seagen.actuators").joinpath("paper.toml").read_text()
    p = tmp_path / "a.toml"
    p.write_text("# reformatted\n" + src.replace(" = ", "="))
    assert load_actuator(p).digest() == default_actuator().digest()
    p.write_text(src.replace("stiffness_n_per_mm = 4.2", "stiffness_n_per_mm = 8.4"))
    assert load_actuator(p).digest() != default_actuator().digest()


def _edit(path: str, value):
    """The paper's description with one field set (None deletes it)."""
    d = _paper()
    *tables, key = path.split(".")
    node = d
    for t in tables:
        node = node[t]
    if value is None:
        del node[key]
    else:
        node[key] = value
    return d


BAD = [
    ("motor.gear_ratio", "380", "must be a number"),
    ("motor.counts_per_rev", 12.5, "must be an integer"),
    ("spring.stiffness_n_per_mm", float("nan"), "must be finite"),
    ("spring.stiffness_n_per_mm", -4.2, "must be positive"),
    ("transmission.lead_mm", None, "missing 'transmission.lead_mm'"),
    ("linkage.split_deg", 30.0, "angle_min_deg < split_deg < angle_max_deg"),
    ("linkage.home_deg", 2.0, "home_deg"),
    ("linkage.h_fit", [], "non-empty array"),
    ("linkage.h_fit", [0.5, "x"], "h_fit[1]"),
    ("pot.adc_bits", 20, "8..16"),
    ("motor.volts", 12.0, "unknown key 'motor.volts'"),
    ("kind", "rotary", "not supported"),
    ("control.d_alpha", 1.5, "'control.d_alpha' must lie in (0, 1]"),
    ("control.kp_v_per_mm", -1.0, "'control.kp_v_per_mm' must be >= 0"),
    ("control.force_max_n", 0.0, "'control.force_max_n' must be positive"),
    ("control.limit_v", "6", "'control.limit_v' must be a number"),
    ("control.gain", 1.0, "unknown key 'control.gain'"),
    ("pot.vref_mv", 0.0, "'pot.vref_mv' must be positive"),
    ("pot.vref_mv", "3.3 V", "'pot.vref_mv' must be a number"),
    ("pot.vref", 3300.0, "unknown key 'pot.vref'"),
    ("control.pot_avg_hz", -10.0, "'control.pot_avg_hz' must be positive"),
    ("control.limit_v", 12.5, "'control.limit_v' 12.5 V is above 'motor.supply_v' 12 V"),
    ("control.force_max_n", 151.0, "'control.force_max_n' 151 N is above 'motor.stall_force_n' 150 N"),
]


@pytest.mark.parametrize("field,value,msg", BAD, ids=[f"{f}={v!r}" for f, v, _ in BAD])
def test_bad_description_names_file_and_field(field, value, msg):
    """Every bad field is refused with a message naming the file and the field."""
    with pytest.raises(ActuatorError) as e:
        actuator_from_dict(_edit(field, value), "my_sea.toml")
    text = str(e.value)
    assert text.startswith("my_sea.toml: ") and msg in text and "\n" not in text


def test_shipped_descriptions_pass_the_plausibility_checks_with_unchanged_hashes():
    """The paper's and the example's descriptions load and keep the hashes their model files record."""
    assert default_actuator().digest()[:12] == "86b7cb236f33"
    assert load_actuator(EXAMPLE_ACTUATOR).digest()[:12] == "7bf39d34fadf"


def test_command_limit_and_force_range_must_fit_the_motor():
    """A limit_v above the supply is refused; the paper's 6.5 V (left out, or written out as data folders'
    actuator.toml do) is capped by the controller on a 6 V motor and accepted; a force range above the stall
    force is refused, written or not."""
    d = _edit("motor.supply_v", 6.0)
    del d["control"]["limit_v"]
    act = actuator_from_dict(d, "six.toml")
    assert act.control.limit_v == 6.5 and actuator_from_dict(act.to_dict(), "actuator.toml") == act
    d["control"]["limit_v"] = 7.0
    with pytest.raises(
        ActuatorError, match=r"^six.toml: 'control.limit_v' 7 V is above 'motor.supply_v' 6 V"
    ):
        actuator_from_dict(d, "six.toml")
    d = _edit("motor.stall_force_n", 15.0)
    del d["control"]["force_max_n"]
    with pytest.raises(ActuatorError, match=r"force_max_n' 20 N \(the paper's default\) is above"):
        actuator_from_dict(d, "weak.toml")


def test_unreadable_files(tmp_path):
    """A missing file, a binary file and broken TOML are one-line errors naming the file."""
    with pytest.raises(ActuatorError, match="no such file"):
        load_actuator(tmp_path / "none.toml")
    b = tmp_path / "bin.toml"
    b.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ActuatorError, match="bin.toml: not valid TOML"):
        load_actuator(b)


def test_control_fields_are_optional_and_default_to_the_papers():
    """A description without the [control] gains and force range takes the paper's, with the same hash as
    one that writes them out (so descriptions and model files from before the fields keep theirs); other
    values change the hash and round-trip through a model file's record."""
    from seagen.actuator import actuator_from_record

    d = _paper()
    bare = {k: v for k, v in d["control"].items() if k == "loop_hz"}
    a = actuator_from_dict({**d, "control": bare}, "bare.toml")
    assert a.control == default_actuator().control and a.digest() == default_actuator().digest()
    assert set(a.record()["values"]["control"]) == {"loop_hz"}
    d["control"]["kp_v_per_mm"] = 40.0
    b = actuator_from_dict(d, "tuned.toml")
    assert b.digest() != a.digest() and b.record()["values"]["control"] == {
        "loop_hz": 100.0,
        "kp_v_per_mm": 40.0,
    }
    assert actuator_from_record(b.record(), "m.pt") == b


def test_pot_reference_and_pot_average_are_optional_and_default_to_the_papers():
    """pot.vref_mv and control.pot_avg_hz: left out, the paper's (3.3 V, 10 Hz) with the same hash as the
    paper's file; another value is recorded, changes the hash and reaches its reader (the rig log's pot in
    mV, the controller's pot-average ticks)."""
    from seagen.discrepancy.riglog import rig_map
    from seagen.runtime.actq import act_q

    d = _paper()
    del d["pot"]["vref_mv"], d["control"]["pot_avg_hz"]
    a = actuator_from_dict(d, "bare.toml")
    assert a == default_actuator() and a.digest() == default_actuator().digest()
    assert (
        "vref_mv" not in a.record()["values"]["pot"] and "pot_avg_hz" not in a.record()["values"]["control"]
    )
    d["pot"]["vref_mv"], d["control"]["pot_avg_hz"] = 5000.0, 25.0
    b = actuator_from_dict(d, "other.toml")
    assert b.digest() != a.digest() and b.record()["values"]["pot"]["vref_mv"] == 5000.0
    assert "full_scale = 5000.0" in rig_map(b) and "full_scale = 3300.0" in rig_map(a)
    assert (act_q(a).pot_avg_ticks, act_q(b).pot_avg_ticks) == (10, 4)
    d["control"]["pot_avg_hz"] = 200.0  # faster than the 100 Hz loop: the C constants are refused
    with pytest.raises(ActuatorError, match="below the 200 Hz of the pot average \\(control.pot_avg_hz\\)"):
        act_q(actuator_from_dict(d, "fast.toml"))


def test_a_refusal_names_the_fields_that_differ():
    """Two descriptions of one name that differ in a controller setting: the model's and the data's refusal
    name the field and both values (the message showed the same name twice and two hashes); the names
    are left out of the list when other fields differ, and at most three fields are spelled out."""
    import dataclasses

    from seagen.data.schema import data_actuator
    from seagen.modelfile import same_actuator

    paper = default_actuator()
    tuned = dataclasses.replace(paper, control=dataclasses.replace(paper.control, limit_v=9.0))
    assert paper.differences(tuned) == "control.limit_v 9.0, not 6.5"
    with pytest.raises(ActuatorError, match=r"the given one has control\.limit_v 9\.0, not 6\.5$"):
        same_actuator(paper, tuned, "m.pt")
    other = load_actuator(EXAMPLE_ACTUATOR)
    said = paper.differences(other)
    assert not said.startswith("name") and said.endswith(" more") and said.count(";") == 2
    renamed = dataclasses.replace(paper, name="mine")
    assert paper.differences(renamed) == "name 'mine', not " + repr(paper.name)
    with pytest.raises(ActuatorError, match=r"control\.limit_v 9\.0, not 6\.5\); drop"):
        data_actuator("/nonexistent-folder", tuned)
