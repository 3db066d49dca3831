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


def test_same_models_agree_to_rounding_and_differences_are_their_constants(monkeypatch):
    pytest.importorskip("Basilisk", reason="Basilisk (bsk) is the [peers] extra")
    from rigid_env.bench import peers_cases

    monkeypatch.setattr(peers_cases, "one_orbit", lambda: 120)  # the coils' run: 2 min of it
    rows = {row.quantity: row for row in peers_cases.agreements(4)}
    run = rows.pop("body rate, coils in the dipole on an orbit, both propagating, 120 s")
    assert "where the field is sampled" in run.cause and run.matched < 1e-3 * run.difference
    run = rows.pop("body rate, gravity gradient on an orbit, both propagating, 120 s")
    assert "where the position is sampled" in run.cause and run.difference < 1e-8
    run = rows.pop("body rate, SRP and drag on 3 plates on an orbit, both propagating, 120 s")
    assert "where the Sun" in run.cause and run.matched < 1e-2 * run.difference
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


def test_a_propagated_coil_run_differs_by_where_the_field_is_sampled_and_by_rk4_alone():
    """The coils' run propagated on both sides (orbit and attitude), 300 s at substeps of 0.1
    and 0.05 s. As Basilisk samples the field (each substep's start, the epoch's coefficients)
    the difference is first order in the substep: halving it halves the difference (the ratio
    2 within 20 %: the next order is (n h)^2 ~ 1e-8 of it, the tumble's (w h)^2 ~ 2.5e-5). With
    the field sampled as ours (the middle, the secular change), what is left is two rk4s on
    different attitude coordinates: fourth order, a ratio of 16; above 8 leaves room for the
    rounding floor (1e-14 against the 1e-12 measured at 0.05 s) and the fifth-order term."""
    pytest.importorskip("Basilisk", reason="Basilisk (bsk) is the [peers] extra")
    from rigid_env.bench.peers_cases import coil_run

    plain = [coil_run(300, h) for h in (0.1, 0.05)]
    matched = [coil_run(300, h, matched=True) for h in (0.1, 0.05)]
    assert 1.6 < plain[0] / plain[1] < 2.4, plain
    assert matched[0] / matched[1] > 8.0, matched
    assert matched[1] < 1e-6 * plain[1], (plain, matched)


def test_a_propagated_gravity_gradient_run_differs_at_second_order():
    """The gravity gradient's run propagated on both sides, 300 s at substeps of 0.1 and 0.05 s.
    Ours holds the position over each substep at its middle, Basilisk's effector reads it at
    each rk4 stage: a second-order difference, so halving the substep quarters it (the ratio 4
    within 20 %: the next term, the rk4s' fourth-order one, is under 1 % of it at these steps,
    rounding 1e-5 of it). The size bound, 1e-7 of the rate, keeps it far below the coils' run's
    first-order 1e-4: the gradient turns with the orbit, (n h)^2 ~ 1e-8 a substep at 0.1 s."""
    pytest.importorskip("Basilisk", reason="Basilisk (bsk) is the [peers] extra")
    from rigid_env.bench.peers_cases import gradient_run

    coarse, fine = (gradient_run(300, h) for h in (0.1, 0.05))
    assert 3.2 < coarse / fine < 4.8, (coarse, fine)
    assert coarse < 1e-7, coarse


def test_a_propagated_run_in_sunlight_and_air_differs_by_sampling_and_by_the_air_alone():
    """SRP and drag on the plates, propagated on both sides, 300 s at substeps of 0.1 and 0.05
    s. As Basilisk samples its inputs (each substep's start) the difference is first order:
    halving the substep halves it (the ratio 2 within 20 %; the pressure constant's and the
    orbit's shares grow with time, not with the substep, and are under 1 % of it at 300 s). With
    the inputs sampled as ours, our pressure and Basilisk's hub too heavy to leave its orbit,
    what is left is the air's velocity (held over a substep here, the hub's at each rk4 stage
    there): second order, a ratio of 4 within 20 % (the rk4s' fourth-order term under 1 %)."""
    pytest.importorskip("Basilisk", reason="Basilisk (bsk) is the [peers] extra")
    from rigid_env.bench.peers_cases import surroundings_run

    plain = [surroundings_run(300, h) for h in (0.1, 0.05)]
    matched = [surroundings_run(300, h, matched=True) for h in (0.1, 0.05)]
    assert 1.6 < plain[0] / plain[1] < 2.4, plain
    assert 3.2 < matched[0] / matched[1] < 4.8, matched
    assert matched[1] < 1e-3 * plain[1], (plain, matched)
