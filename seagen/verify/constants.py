"""The headers' integer constants as the firmware compiles them: a small C unit built against the headers on
disk returns each #define, compared with the values this seagen writes for the export (NAME_OUT_Q, ...)."""

from __future__ import annotations

from pathlib import Path

from seagen.c_runtime import COMMENT, define_of


def expected(rendered: dict[str, str]) -> dict[str, tuple[str, int]]:
    """Every integer #define of the export's headers as written: NAME -> (header, value)."""
    out: dict[str, tuple[str, int]] = {}
    for name, text in sorted(rendered.items()):
        if name.endswith(".h"):
            for line in COMMENT.sub("", text).splitlines():
                if (d := define_of(line)) is not None:
                    out.setdefault(d[0], (name, d[1]))
    return out


def probe_sources(prefix: str, macros: list[str], headers: list[str]) -> dict[str, str]:
    """The probe unit: `PREFIX_seagen_constants(out)` writes each macro (or INT64_MIN when undefined) as
    seen after including `headers`."""
    fn = f"{prefix}_seagen_constants"
    body = "".join(
        f"#ifdef {m}\n    out[{k}] = (int64_t)({m});\n#else\n    out[{k}] = INT64_MIN;\n#endif\n"
        for k, m in enumerate(macros)
    )
    header = f"#include <stdint.h>\nvoid {fn}(int64_t *out);\n"
    return {
        f"{prefix}_seagen_probe.h": header,
        f"{prefix}_seagen_probe.c": f'#include "{prefix}_seagen_probe.h"\n'
        + "".join(f'#include "{h}"\n' for h in headers)
        + f"void {fn}(int64_t *out) {{\n{body}}}\n",
    }


def compiled_values(files: dict[str, str], prefix: str, macros: list[str]) -> list[int]:
    """The macros' values as the C compiler sees them through the headers in `files`."""
    from seagen.toolchain.host import build

    headers = {n: t for n, t in sorted(files.items()) if n.endswith(".h")}
    probe = probe_sources(prefix, macros, list(headers))
    mod = build(f"void {prefix}_seagen_constants(int64_t *out);", {**headers, **probe}, name=f"{prefix}_k")
    out = mod.ffi.new("int64_t[]", max(len(macros), 1))
    getattr(mod.lib, f"{prefix}_seagen_constants")(out)
    return [int(out[k]) for k in range(len(macros))]


def constants_problem(
    folder: Path, files: dict[str, str], rendered: dict[str, str], prefix: str
) -> str | None:
    """The first header constant whose compiled value differs from the export's, named; or None."""
    want = expected({n: t for n, t in rendered.items() if n in files})
    macros = sorted(want)
    got = compiled_values(files, prefix, macros)
    bad = [(m, v) for m, v in zip(macros, got, strict=True) if v != want[m][1]]
    if not bad:
        return None
    m, v = bad[0]
    header, value = want[m]
    now = "not defined" if v == -(2**63) else f"{v}"
    more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
    return f"{folder / header}: {m} compiles to {now}; the export's value is {value}{more}"
