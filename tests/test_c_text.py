"""Every user string that reaches the generated C is safe where it lands: text that could end a comment,
splice a line or add a token is refused (one line naming the file and the field, exit 2), text that is
accepted leaves the C's token stream (gcc -E, comments removed, trigraphs and splices applied) exactly as
with a plain unit, and names that map to one C identifier are refused. ~6 s."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from pathlib import Path

import pytest
import torch

from seagen import cnames
from seagen.cli import main
from seagen.codegen import cfmt
from seagen.codegen.render import render
from seagen.defaults import GENERATED
from seagen.errors import UserError
from seagen.export import prepare
from seagen.modelfile import load_model
from seagen.toolchain.host import STRICT_CFLAGS
from tests import table_models as T

SF = GENERATED / "models" / "sf_calibration.pt"
# Each can end a comment, start one (gcc -Wcomment), splice a line (backslash, the trigraph ??/), break the
# line or leave ASCII.
HOSTILE = [
    "*/ int evil; /*",
    "N */",
    "/* N",
    "N\\",
    "N??/",
    "N\nint evil;",
    "N\r",
    "\t",
    "N\x0c",
    "N\u2028",
    "N/\u00b7",  # written N/* in the C
    "\u00b7/",  # written */
    "\u202eN",  # a right-to-left override
]
# Units as people write them, and how the C comments spell them (the manifest keeps them as written).
NON_ASCII = {
    "N\u00b7m": "N*m", "\u00b0": "deg", "\u00b5m": "um", "\u03a9": "Ohm", "\u2126": "Ohm",
    "m/s\u00b2": "m/s^2", "s\u207b\u00b9": "s^-1", "\u00b0C": "degC", "\u2103": "degC",
    "k\u03a9\u00b7cm": "kOhm*cm", "caf\u00e9": "cafe", "\u65e5": "<U+65E5>",
}  # fmt: skip
TRICKY = ["N*m", "m/s^2", "a / *b", '"q" #define X 1', "'c' // x", "? ?/", "*", "/", "N ?/", "x;y{}"]
needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no host gcc")


def sf_with(tmp: Path, **fields: object) -> Path:
    """The shipped SF model with some top-level fields replaced."""
    d = load_model(SF) | fields
    p = tmp / "sf_user.pt"
    torch.save(d, p)
    return p


@pytest.mark.parametrize("field", ["output_name", "output_units", "input_units"])
@pytest.mark.parametrize("text", HOSTILE)
def test_hostile_text_refused_naming_file_and_field(field, text, tmp_path, capsys):
    """Text that could change the C where it lands: exit 2, one line naming the file and the field."""
    value = [text, "mm"] if field == "input_units" else text
    p = sf_with(tmp_path, **{field: value})
    out = tmp_path / "out"
    rc = main(["export", str(p), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert "sf_user.pt" in err and f"field '{field}" in err and "Traceback" not in err, err
    assert not out.exists()


def test_hostile_text_in_a_features_file_names_that_file(tmp_path, capsys):
    """A unit in a --features file is refused naming the spec file."""
    spec = json.loads(T.spec_file(tmp_path).read_text()) | {"input_units": ["N", "*/", "mm"]}
    sp = tmp_path / "units.json"
    sp.write_text(json.dumps(spec))
    net = tmp_path / "seq.pt"
    torch.save(T.seq(torch.nn.ReLU()), net)
    rc = main(["export", str(net), "--features", str(sp), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2 and "units.json: field 'input_units[1]'" in err, err


def _tokens(out: Path, prefix: str) -> str:
    """gcc's preprocessed NAME.c (NAME.h included): comments removed, trigraphs and line splices applied."""
    cmd = ["gcc", "-std=c99", "-E", "-P", "-I", str(out), str(out / f"{prefix}.c")]
    return subprocess.run(cmd, capture_output=True, text=True, check=True).stdout


def _export_dir(tmp: Path, name: str, unit: str, out_name: str) -> Path:
    """Export the SF model with the given texts into tmp/name (prefix m)."""
    p = sf_with(tmp, output_units=unit, output_name=out_name, input_units=[unit, "mm"])
    out = tmp / name
    assert main(["export", str(p), "--out", str(out), "--prefix", "m"]) == 0
    return out


@needs_gcc
def test_accepted_text_leaves_the_c_tokens_unchanged_and_compiles(tmp_path):
    """Every accepted tricky text: the preprocessed C equals the one with plain text (the text lives only
    in comments), and the C compiles with the strict flags."""
    base = _tokens(_export_dir(tmp_path, "base", "N", "force_n"), "m")
    for i, text in enumerate(TRICKY):
        out = _export_dir(tmp_path, f"t{i}", text, f"y {text}")
        assert text in (out / "m.h").read_text()
        assert _tokens(out, "m") == base, text
    flags = [f for f in STRICT_CFLAGS if f != "-O2"]
    subprocess.run(
        ["gcc", *flags, "-c", "-I", str(out), str(out / "m.c"), "-o", str(tmp_path / "m.o")], check=True
    )


def test_ascii_spelling_of_units():
    """The explicit table, superscripts, accents stripped, and the <U+XXXX> fallback."""
    for text, spelled in NON_ASCII.items():
        assert cnames.comment_ascii(text) == spelled, text
        assert cnames.comment_problem(text) is None, text


@needs_gcc
def test_non_ascii_units_written_as_ascii_kept_in_the_manifest(tmp_path):
    """Units such as N·m, °, µm, Ω: the C is ASCII with their spelling in the comments, its tokens are those
    of a plain unit, and the manifest keeps the text as written."""
    base = _tokens(_export_dir(tmp_path, "base", "N", "force_n"), "m")
    for i, (text, spelled) in enumerate(NON_ASCII.items()):
        out = _export_dir(tmp_path, f"u{i}", text, f"torque {text}")
        h = (out / "m.h").read_text()
        assert h.isascii() and f"[{spelled}]" in h and f"torque {spelled}" in h, text
        assert _tokens(out, "m") == base, text
        resolved = json.loads((out / "m.seagen.json").read_text())["resolved"]
        assert resolved["output"] == [f"torque {text}", text] and resolved["inputs"][0][1] == text


@needs_gcc
def test_the_token_check_sees_a_hostile_text_that_got_through(tmp_path, monkeypatch):
    """The check above can fail: with the guard filter switched off, a unit '*/ int evil; /*' adds tokens;
    with it on, rendering refuses the text."""
    ex = prepare(str(SF), "m")
    hostile = dataclasses.replace(
        ex.qmodel, output=dataclasses.replace(ex.qmodel.output, unit="*/ int evil; /*")
    )
    with pytest.raises(UserError, match="cannot be written into a C comment"):
        render(hostile, "m")
    out = tmp_path / "plain"
    out.mkdir()
    for name, text in ex.files.items():
        (out / name).write_text(text)
    base = _tokens(out, "m")
    monkeypatch.setattr(cfmt, "comment_problem", lambda text: None)
    (out / "m.h").write_text(render(hostile, "m")["m.h"])
    assert "evil" in _tokens(out, "m") and _tokens(out, "m") != base


def test_render_guards_names_and_texts():
    """Where the text lands: an input name that is not an identifier, inputs whose macros are one, or a
    unit that could end a comment are refused by the renderer even if a loader let them through."""
    qm = prepare(str(SF), "m").qmodel
    a, b = qm.inputs

    def named(n0: str, n1: str, unit: str = "deg"):
        sig0 = dataclasses.replace(a.signal, name=n0, unit=unit)
        sig1 = dataclasses.replace(b.signal, name=n1)
        return dataclasses.replace(
            qm, inputs=(dataclasses.replace(a, signal=sig0), dataclasses.replace(b, signal=sig1))
        )

    with pytest.raises(UserError, match="give one C macro M_IN_Q_A"):
        render(named("a", "A"), "m")
    long0, long1 = "x" * 30 + "a", "x" * 30 + "b"  # the macros differ only after the 63rd character
    with pytest.raises(UserError, match="give one C macro"):
        render(named(long0, long1), "p" * 31)
    assert "P_IN_Q_" + long0.upper() in render(named(long0, long1), "p")["p.h"]
    with pytest.raises(UserError, match="not a C identifier"):
        render(named("a*/b", "c"), "m")
    with pytest.raises(UserError, match="C comment"):
        render(named("a", "b", unit="deg\\"), "m")


@pytest.mark.parametrize("inputs", [["a", "A"], ["force", "FORCE", "x"]], ids=["a-A", "force-FORCE"])
def test_inputs_differing_only_in_case_refused(inputs, tmp_path, capsys):
    """Two inputs whose names differ only in case (one NAME_IN_Q_ macro): exit 2 naming the spec file."""
    n = len(inputs)
    spec = {"inputs": inputs, "mean": [0.0] * n, "std": [1.0] * n, "input_range": [[0.0, 1.0]] * n}
    sp = tmp_path / "case.json"
    sp.write_text(json.dumps(spec))
    net = tmp_path / "net.pt"
    torch.save(torch.nn.Sequential(torch.nn.Linear(n, 2), torch.nn.ReLU(), torch.nn.Linear(2, 1)), net)
    rc = main(["export", str(net), "--features", str(sp), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2 and "case.json: field 'inputs'" in err and "differ only in case" in err, err


@pytest.mark.parametrize("prefix", ["abc\n", "abc\\", "a*/b", "_x", "x" * 32])
def test_prefix_must_be_a_whole_identifier(prefix, capsys, tmp_path):
    """--prefix is matched whole (a trailing newline is not an identifier character)."""
    assert main(["export", str(SF), "--out", str(tmp_path / "o"), "--prefix", prefix]) == 2
    assert "invalid prefix" in capsys.readouterr().err


@pytest.mark.parametrize(
    "name", ["case.pt", "sea_x.pt", "1.pt", "a" * 40 + ".pt", "my model (v2).onnx", "SEA.pt", "\u00e9.pt"]
)
def test_default_prefix_is_always_a_valid_one(name):
    """Without --prefix, any file name gives a prefix the checks accept (no refusal of a name the user
    did not choose)."""
    from seagen.export import default_prefix

    assert cnames.assert_valid_prefix(default_prefix(name)) == default_prefix(name)


def test_default_prefix_from_a_keyword_file_name_exports(tmp_path):
    """A model file named after a C keyword exports with m_ before the name."""
    p = tmp_path / "case.pt"
    shutil.copy(SF, p)
    assert main(["export", str(p), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "m_case.h").is_file()


def test_every_user_text_placeholder_in_the_templates_is_filtered():
    """Each template placeholder printing a user name or text (input and output names and units, external
    argument names, the model summary) goes through c_ident or c_comment."""
    import re

    root = Path(__file__).resolve().parents[1] / "templates"
    user = re.compile(r"signal\.|output\.(name|unit)|externals|\bf\.name|^\s*line\s*$")
    unfiltered = []
    for t in sorted(root.glob("*.j2")):
        for expr in re.findall(r"\{\{(.*?)\}\}", t.read_text()):
            if user.search(expr) and not re.search(r"\|\s*(c_ident|c_comment)|map\('c_ident'\)", expr):
                unfiltered.append(f"{t.name}: {{{{{expr}}}}}")
    assert not unfiltered, unfiltered
