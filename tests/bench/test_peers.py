"""`rigid-env bench peers`: where this package and Basilisk compute the same model with the same
constants they agree to rounding, and each difference the table reports is the constant or model
it names; without the [peers] extra the command says so in one line."""

from __future__ import annotations

import sys

import pytest

from rigid_env.bench import peers
from rigid_env.cli import main


def test_without_basilisk_the_command_names_the_extra(monkeypatch, capsys):
    # None in sys.modules makes the import fail as if Basilisk were not installed.
    monkeypatch.setitem(sys.modules, "Basilisk", None)
    monkeypatch.delitem(sys.modules, "rigid_env.bench.peers_cases", raising=False)
    assert main(["bench", "peers", "--cases", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install -e '.[peers]'" in err[0] and "Traceback" not in err[0]


def test_same_models_agree_to_rounding_and_differences_are_their_constants():
    pytest.importorskip("Basilisk", reason="Basilisk (bsk) is the [peers] extra")
    from rigid_env.bench import peers_cases

    rows = {row.quantity: row for row in peers_cases.agreements(4)}
    for row in rows.values():
        # With the named constant or model matched, every row is the same arithmetic on both
        # sides: ROUNDING (1e-12 of the quantity) bounds a few dozen roundings with margin.
        assert row.matched <= peers_cases.ROUNDING, row
    drag = "drag torque on 3 plates, through the world on its orbit (Basilisk given its wind)"
    assert rows[drag].cause == "rounding"
    # The gravity-gradient torque is linear in mu: its difference is the two mu's ratio.
    gradient = rows["gravity-gradient torque"]
    assert gradient.difference == pytest.approx(1.4550913e-8, rel=1e-4)  # 3.986004418 / ...360
    assert "mu" in gradient.cause
    light = rows["solar radiation pressure torque on 3 plates, through the world on its orbit"]
    assert "solar pressure" in light.cause
    # The pressure constants differ by 0.51 % (1361 W/m^2 here): the difference is their ratio.
    assert light.difference == pytest.approx(0.0051, abs=2e-4)
    assert rows["body rate, 3 wheels under a torque profile, 60 s"].cause.startswith("rounding")
    for same in ("centred-dipole field (IGRF-13 2020)", "IGRF-14 2025 to degree 1"):
        assert rows[same].cause == "rounding"
    assert rows["coils' torque in the dipole field"].cause == "rounding"
    orbit = "coils' torque through the world on its orbit (IGRF-14 to degree 1 where the body is)"
    assert rows[orbit].cause == "rounding"
    # IGRF's higher degrees move the field by tens of percent in LEO (the issue: 0.71-1.73x).
    assert 0.05 < rows["IGRF-14 2025 to degree 13, against the dipole"].difference < 1.0
    text = peers.markdown(list(rows.values()), [])
    assert text.count("\n| ") == len(rows) + 2  # two tables' header lines and one per row
