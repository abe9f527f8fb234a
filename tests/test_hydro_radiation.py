"""Tests of plant.hydro.radiation: Perez-Fossen kernel fits and the radiation state space.

Error measures (defined in ``KernelFit``): relative to the largest value over the fitted band,
``error_added_mass = max|Â - A| / max|A - A_∞|``, ``error_damping = max|B̂ - B| / max|B|``,
``error_k = max|K̂ - K| / max|K|``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from plant.hydro.radiation import (
    KernelFit,
    RadiationSS,
    fit_kernel,
    fit_radiation,
    kernel_response,
    retardation_kernel,
)
from plant.hydro.wamit import RadiationData, load_hydro_preset

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
TLP = REFERENCE / "nrel-5mw-tlp-buoy"
SS_FILE = (
    REFERENCE
    / "openfast"
    / "IEA-15-240-RWT-UMaineSemi"
    / "HydroData"
    / "IEA-15-240-RWT-UMaineSemi.ss"
)
TLP_BAND = 2.1  # rad/s: irregular frequencies of the BEM run begin near 2.2 rad/s
SEMI_BAND = (0.0, 3.0)  # rad/s: wave band with margin; B of heave/pitch has decayed by 3 rad/s


def need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"reference {path} absent (../shared/reference not checked out)")
    return path


@pytest.fixture(scope="module")
def tlp() -> RadiationData:
    rad = load_hydro_preset("nrel5mw_tlp_buoy").radiation
    keep = rad.omega_rad_s <= TLP_BAND
    return RadiationData(
        omega_rad_s=rad.omega_rad_s[keep],
        added_mass=rad.added_mass[keep],
        damping=rad.damping[keep],
        added_mass_inf=rad.added_mass_inf,
        dofs=rad.dofs,
    )


@pytest.fixture(scope="module")
def semi_ss() -> RadiationSS:
    rad = load_hydro_preset("iea15mw_volturnus").radiation
    return fit_radiation(rad, dofs=(0, 2, 4), max_order=10, omega_range_rad_s=SEMI_BAND)


def tlp_fit(tlp: RadiationData, order: int | None) -> KernelFit:
    return fit_kernel(
        tlp.omega_rad_s,
        tlp.added_mass[:, 0, 0],
        tlp.damping[:, 0, 0],
        float(tlp.added_mass_inf[0, 0]),
        order=order,
    )


# ------------------------------------------------------------------------------ TLP buoy
def test_tlp_surge_order4_reproduces_a_and_b(tlp: RadiationData) -> None:
    fit = tlp_fit(tlp, 4)
    assert fit.order == 4
    # Measured: A 0.43 %, B 0.44 %, K 0.71 % (max over 0.05..2.1 rad/s). Brief's bound: 2 %.
    assert fit.error_added_mass < 0.02
    assert fit.error_damping < 0.02
    assert fit.error_k < 0.02
    assert np.all(fit.poles.real < 0.0)
    assert fit.reflected_poles == 0
    # Structure: zero at s = 0, relative degree 1, monic denominator.
    assert fit.numerator[-1] == 0.0
    assert fit.denominator.size == fit.numerator.size + 1
    assert fit.denominator[0] == 1.0
    # Pointwise where B is sizeable (> 10 % of its peak): within 2 %.
    w = tlp.omega_rad_s
    b = tlp.damping[:, 0, 0]
    big = b > 0.1 * b.max()
    np.testing.assert_allclose(fit.damping(w[big]), b[big], rtol=0.02)
    # B peak of the reference README: 7.63e5 N s/m near 1.31 rad/s.
    grid = np.linspace(0.05, 2.1, 2000)
    b_fit = fit.damping(grid)
    assert b_fit.max() == pytest.approx(7.63e5, rel=0.01)
    assert grid[np.argmax(b_fit)] == pytest.approx(1.31, abs=0.03)


def test_tlp_automatic_order_is_4(tlp: RadiationData) -> None:
    # Order 3 has a 3.1 % error on A: above the 2 % tolerance, so order 4 is the lowest.
    assert tlp_fit(tlp, 3).fit_error > 0.02
    fit = tlp_fit(tlp, None)
    assert fit.order == 4
    assert fit.meets_tol


def test_tlp_fit_agrees_with_reference_order4_fit(tlp: RadiationData) -> None:
    ref = json.loads(need(TLP / "radiation_fit_order4_h100.json").read_text())
    num = np.array(ref["num_descending_powers_of_s"])
    den = np.array(ref["den_descending_powers_of_s"])
    w = tlp.omega_rad_s
    k_data = kernel_response(w, tlp.added_mass[:, 0, 0], tlp.damping[:, 0, 0], 1.665472e6)
    k_ref = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
    k_ours = tlp_fit(tlp, 4).response(w)
    scale = np.max(np.abs(k_data))
    # Each is within 0.4 % (reference) and 0.7 % (ours) of the data, so they agree within 1.2 %.
    assert np.max(np.abs(k_ref - k_data)) / scale < 0.005
    assert np.max(np.abs(k_ours - k_ref)) / scale < 0.012
    # Same high-frequency gain k(0+) = lim s K(s) = leading numerator coefficient: 5 %.
    assert tlp_fit(tlp, 4).numerator[0] == pytest.approx(num[0], rel=0.05)


def test_state_space_realises_transfer_function(tlp: RadiationData) -> None:
    fit = tlp_fit(tlp, 4)
    A, B, C, D = fit.state_space()
    assert A.shape == (4, 4) and B.shape == (4, 1) and C.shape == (1, 4)
    assert D[0, 0] == 0.0
    w = np.array([0.1, 0.7, 1.3, 5.0])
    g = np.array([(C @ np.linalg.solve(1j * x * np.eye(4) - A, B))[0, 0] for x in w])
    np.testing.assert_allclose(g, fit.response(w), rtol=1e-10)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)), np.sort_complex(fit.poles))


def test_unstable_poles_are_reflected() -> None:
    # A kernel whose least-squares fit wants a right-half-plane pole: K(s) = s/((s-0.3)^2 + 1).
    w = np.linspace(0.05, 3.0, 60)
    k_true = 1j * w / ((1j * w - 0.3) ** 2 + 1.0)
    fit = fit_kernel(w, k_true.imag / w, k_true.real, 0.0, order=2)
    assert fit.reflected_poles == 2
    assert np.all(fit.poles.real < 0.0)
    # Reflection keeps |K| (all-pass factor) but not the phase: the fit error is reported.
    assert fit.fit_error > 0.02 and not fit.meets_tol
    assert not fit.passive  # Re K = B < 0 somewhere: reported, not fixed


def test_fit_kernel_input_errors() -> None:
    w = np.linspace(0.1, 2.0, 20)
    a, b = np.ones(20), np.ones(20)
    with pytest.raises(ValueError, match="order must be >= 2"):
        fit_kernel(w, a, b, 0.0, order=1)
    with pytest.raises(ValueError, match="strictly increasing"):
        fit_kernel(w[::-1], a, b, 0.0)
    with pytest.raises(ValueError, match="equal length"):
        fit_kernel(w, a[:5], b, 0.0)
    with pytest.raises(ValueError, match="identically zero"):
        fit_kernel(w, a, 0 * b, 1.0)
    with pytest.raises(ValueError, match="too few"):
        fit_kernel(w[:4], a[:4], b[:4], 0.0, order=5)


# ------------------------------------------------------------------------------ VolturnUS-S
def _diag_fit(ss: RadiationSS, pos: int) -> KernelFit:
    return ss.fits[ss.pairs.index((pos, pos))]


def test_semi_heave_pitch_within_2_percent(semi_ss: RadiationSS) -> None:
    # Measured (0.05..3 rad/s, automatic order): heave order 7, A 1.0 %, B 1.3 %, K 1.4 %;
    # pitch order 7, A 1.7 %, B 1.8 %, K 2.0 %.
    for pos in (1, 2):
        fit = _diag_fit(semi_ss, pos)
        assert fit.meets_tol, fit
        assert fit.error_added_mass < 0.02 and fit.error_damping < 0.02
        assert fit.order <= 8
        assert np.all(fit.poles.real < 0.0)
        # Passivity is reported: slightly negative Re K̂ (heave -1.1 %, pitch -0.2 % of max|K|)
        # outside the band; the flag says so, nothing is silently changed.
        assert fit.passive == (fit.real_part_min >= -1e-9)
        assert fit.real_part_min > -0.02


def test_semi_surge_reports_unmet_tolerance(semi_ss: RadiationSS) -> None:
    # Surge A(w), B(w) of VolturnUS-S ripple (column interference) with 0.1 rad/s periods that a
    # low-order model does not follow: no order <= 10 reaches 2 % (order 20 reaches 3.2 %).
    # Measured at order 10: K 13.9 %, A 11.9 %, B 12.4 %, RMS K 5 %. OpenFAST's SS_Fitting
    # model of the same data is 20 % off in K (max) and 7 % RMS, so ours is not worse.
    fit = _diag_fit(semi_ss, 0)
    assert not fit.meets_tol
    assert fit.error_k < 0.16
    assert fit.error_rms < 0.06
    assert np.all(fit.poles.real < 0.0)


def test_semi_negligible_kernels_skipped(semi_ss: RadiationSS) -> None:
    # Heave decouples from surge and pitch (symmetry): those kernels are skipped.
    assert set(semi_ss.skipped) == {(0, 1), (1, 0), (1, 2), (2, 1)}
    assert set(semi_ss.pairs) == {(0, 0), (0, 2), (1, 1), (2, 0), (2, 2)}
    assert any("negligible" in line for line in semi_ss.describe())
    assert semi_ss.n_states == sum(f.order for f in semi_ss.fits)


def parse_openfast_ss(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lines = path.read_text().splitlines()
    n = int(lines[2].split()[0])
    rows = [[float(v) for v in line.split()] for line in lines[4 : 4 + 2 * n + 6]]
    A = np.array(rows[:n])
    B = np.array(rows[n : 2 * n])
    C = np.array(rows[2 * n :])
    assert A.shape == (n, n) and B.shape == (n, 6) and C.shape == (6, n)
    return A, B, C


def test_semi_compare_with_openfast_ss(semi_ss: RadiationSS) -> None:
    A, B, C = parse_openfast_ss(need(SS_FILE))
    assert np.max(np.linalg.eigvals(A).real) < 0.0
    rad = load_hydro_preset("iea15mw_volturnus").radiation
    w = np.linspace(0.2, 2.0, 37)
    # OpenFAST's .ss output is the force ON the body (= -μ); ours is μ = C x.
    k_of = -np.array([C @ np.linalg.solve(1j * x * np.eye(A.shape[0]) - A, B) for x in w])
    k_ours = semi_ss.frequency_response(w)
    for pos, mode in ((1, 2), (2, 4)):  # heave-heave, pitch-pitch
        k_data = kernel_response(
            w,
            np.interp(w, rad.omega_rad_s, rad.added_mass[:, mode, mode]),
            np.interp(w, rad.omega_rad_s, rad.damping[:, mode, mode]),
            float(rad.added_mass_inf[mode, mode]),
        )
        scale = np.max(np.abs(k_data))
        err_of = np.max(np.abs(k_of[:, mode, mode] - k_data)) / scale
        err_ours = np.max(np.abs(k_ours[:, pos, pos] - k_data)) / scale
        diff = np.max(np.abs(np.abs(k_ours[:, pos, pos]) - np.abs(k_of[:, mode, mode]))) / scale
        # Measured in 0.2..2 rad/s: OpenFAST's fit is 8.5 % (heave) and 8.9 % (pitch) of
        # max|K| from the data, ours < 2 %; so |K̂| of the two agree within their sum, < 12 %.
        assert err_of < 0.10
        assert err_ours < 0.025
        assert diff < 0.12


def test_semi_impulse_response_equals_retardation_kernel(semi_ss: RadiationSS) -> None:
    rad = load_hydro_preset("iea15mw_volturnus").radiation
    t, k_fit = semi_ss.impulse_response(0.1, 601)  # 0..60 s (RdtnTMax of the deck)
    w = np.concatenate([[0.0], rad.omega_rad_s])  # B(0) = 0
    for pos, mode, tol_all, tol_late in ((2, 4, 0.03, 0.02), (1, 2, 0.10, 0.03)):
        b = np.concatenate([[0.0], rad.damping[:, mode, mode]])
        k_ref = retardation_kernel(t, w, b)
        scale = np.max(np.abs(k_ref))
        err = np.abs(k_fit[:, pos, pos] - k_ref) / scale
        # Pitch (measured max 2.5 %, at t = 0) and heave (max 9.4 % at t = 0, 3.6 % at 0.7 s,
        # 2.3 % after 1 s): k(0+) = (2/π)∫B̂ dω depends on the fit's B̂ tail above the 3 rad/s
        # band, which the data do not constrain; after the first second they agree to 2-3 %.
        assert err.max() < tol_all
        assert err[t >= 1.0].max() < tol_late
        assert np.sqrt(np.mean(err**2)) < 0.01  # RMS over 60 s: 0.45 % / 0.8 % measured


def test_block_state_space_consistency_and_npz(semi_ss: RadiationSS, tmp_path: Path) -> None:
    w = np.array([0.3, 0.9, 1.7])
    n = semi_ss.n_states
    k_mat = np.array(
        [semi_ss.C @ np.linalg.solve(1j * x * np.eye(n) - semi_ss.A, semi_ss.B) for x in w]
    )
    np.testing.assert_allclose(k_mat, semi_ss.frequency_response(w), rtol=1e-8, atol=1e-6)
    assert np.max(np.linalg.eigvals(semi_ss.A).real) < 0.0
    # A and B from the fit: Â = A_∞ + Im K̂/ω, B̂ = Re K̂.
    np.testing.assert_allclose(
        semi_ss.added_mass(w)[:, 1, 1], _diag_fit(semi_ss, 1).added_mass(w), rtol=1e-12
    )
    # Derivative and memory force.
    x = np.ones(n)
    v = np.array([0.1, 0.2, 0.3])
    np.testing.assert_allclose(semi_ss.derivative(x, v), semi_ss.A @ x + semi_ss.B @ v)
    np.testing.assert_allclose(semi_ss.memory_force(x), semi_ss.C @ x)
    assert semi_ss.passivity_margin(w).shape == (3,)
    f = tmp_path / "ss.npz"
    semi_ss.save_npz(f)
    back = RadiationSS.load_npz(f)
    np.testing.assert_array_equal(back.A, semi_ss.A)
    np.testing.assert_array_equal(back.C, semi_ss.C)
    assert back.pairs == semi_ss.pairs and back.skipped == semi_ss.skipped
    assert back.fits[0].error_k == semi_ss.fits[0].error_k
    with np.load(f, allow_pickle=False) as z:
        assert all(z[k].dtype != object for k in z.files)


def test_shipped_model_diagonal_kernels_are_passive_with_damping_floor() -> None:
    """Shipped IEA 15 MW model: Re K̂_ii ≥ 0 on 1e-4..1e3 rad/s, ≥ 0.5 B_ii at the data."""
    from importlib import resources

    from plant.hydro.radiation import RadiationModel
    from plant.hydro.wamit import HydroData

    hydro_dir = resources.files("plant.presets").joinpath("hydro")
    with resources.as_file(hydro_dir.joinpath("iea15mw_volturnus_radiation.npz")) as path:
        model = RadiationModel.load_npz(path)
    with resources.as_file(hydro_dir.joinpath("iea15mw_volturnus.npz")) as path:
        rad = HydroData.load_npz(path).radiation.select((0, 2, 4))
    w = np.logspace(-4, 3, 6000)
    k = model.frequency_response(w)
    for i in range(3):
        assert np.min(k[:, i, i].real) >= -1e-9 * np.max(np.abs(k[:, i, i])), i
    band = rad.omega_rad_s <= 2.0
    kd = model.frequency_response(rad.omega_rad_s[band])
    for i in range(3):
        b = rad.damping[band, i, i]
        assert np.all(kd[:, i, i].real >= 0.5 * b - 1e-9 * np.max(b)), i
    # Accuracy after the passivity correction: surge, heave and pitch within the 2 % of the
    # issue over 0.05..2 rad/s, recomputed here from the response (not the stored figures).
    wb = rad.omega_rad_s[band]
    for i in range(3):
        a, b, a_inf = rad.added_mass[band, i, i], rad.damping[band, i, i], rad.added_mass_inf[i, i]
        err_a = np.max(np.abs(a_inf + kd[:, i, i].imag / wb - a)) / np.max(np.abs(a - a_inf))
        err_b = np.max(np.abs(kd[:, i, i].real - b)) / np.max(np.abs(b))
        assert err_a < 0.02 and err_b < 0.02, (i, err_a, err_b)
        assert model.error_added_mass[i, i] == pytest.approx(err_a, rel=1e-6)
        assert model.error_damping[i, i] == pytest.approx(err_b, rel=1e-6)
    assert np.max(np.linalg.eigvals(model.A).real) < 0.0


def test_diagonal_max_order_raises_only_the_kernels_that_need_it() -> None:
    """Semi surge misses 2 % at order 12 (column-interference ripple); up to 30 it meets it."""
    rad = load_hydro_preset("iea15mw_volturnus").radiation
    w = rad.omega_rad_s[rad.omega_rad_s <= 2.0]
    kwargs = {"dofs": (0, 2, 4), "max_order": 12, "omega_range_rad_s": (0.0, 2.0)}
    low = fit_radiation(rad, weights=1.0 / w, passive_floor=0.5, **kwargs)  # type: ignore[arg-type]
    high = fit_radiation(
        rad,
        weights=1.0 / w,
        passive_floor=0.5,
        diagonal_max_order=30,
        **kwargs,  # type: ignore[arg-type]
    )
    surge_low = low.fits[low.pairs.index((0, 0))]
    surge_high = high.fits[high.pairs.index((0, 0))]
    assert not surge_low.meets_tol and surge_low.order == 12
    assert surge_high.meets_tol and 12 < surge_high.order <= 30
    assert surge_high.passive
    # Heave and off-diagonal kernels are untouched.
    for pair in ((1, 1), (0, 2), (2, 0)):
        assert low.fits[low.pairs.index(pair)].order == high.fits[high.pairs.index(pair)].order


def _unstable_truncation(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every balanced truncation comes out with its slowest pole (pair) in the right half
    plane, as the ill-conditioned balancing of a large stack can give."""
    import plant.hydro.radiation as rad

    exact = rad.balanced_truncation

    def flipped(a, b, c, order):  # type: ignore[no-untyped-def]
        a_r, b_r, c_r, hsv = exact(a, b, c, order)
        lam, vec = np.linalg.eig(a_r)
        k = int(np.argmax(lam.real))
        moved = lam.copy()
        moved[np.isclose(lam.real, lam[k].real)] *= -1.0  # the pair: σ ± jω -> −σ ∓ jω
        return (vec @ np.diag(moved) @ np.linalg.inv(vec)).real, b_r, c_r, hsv

    monkeypatch.setattr(rad, "balanced_truncation", flipped)


def test_unstable_truncations_are_stabilised_and_said(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reduced model is stable by construction: with every truncation unstable, the
    unstable poles are reflected and the residues refitted (shipped spar data, 0..2 rad/s,
    the OpenFAST importer's options); its diagonal errors stay within the 2 % tolerance or
    the unreduced stack's, and what was done is in its source and its per-pair report."""
    from plant.hydro.radiation import fit_reduced_radiation

    hydro = load_hydro_preset("nrel5mw_oc3_hywind")
    options = {"max_order": 12, "omega_range_rad_s": (0.0, 2.0)}
    plain = fit_reduced_radiation(hydro.radiation, **options)
    assert "fit:" not in plain.source  # the plain reduction is untouched when it works
    _unstable_truncation(monkeypatch)
    model = fit_reduced_radiation(hydro.radiation, **options)
    assert np.max(np.linalg.eigvals(model.A).real) < 0.0
    assert "truncation stabilised" in model.source and "residues refitted" in model.source
    assert model.order < model.fitted_order
    assert np.all(np.diag(model.error_added_mass) <= 0.02)  # 1.4 %, 1.0 %, 0.9 %
    assert np.all(np.diag(model.error_damping) <= 0.02)
    pairs = model.describe_pairs()
    assert [p.split(":")[0] for p in pairs] == ["surge-heave", "surge-pitch", "heave-pitch"]


def test_unreduced_stack_when_no_truncation_can_be_stabilised(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import plant.hydro.radiation as rad

    hydro = load_hydro_preset("nrel5mw_oc3_hywind")
    _unstable_truncation(monkeypatch)
    monkeypatch.setattr(rad, "_refit_residues", lambda *args: None)
    model = rad.fit_reduced_radiation(hydro.radiation, max_order=12, omega_range_rad_s=(0.0, 2.0))
    assert model.order == model.fitted_order
    assert np.max(np.linalg.eigvals(model.A).real) < 0.0
    assert "unreduced" in model.source
    assert np.all(np.diag(model.error_damping) <= 0.03)
