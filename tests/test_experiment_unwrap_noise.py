"""unwrap-noise experiment (quick variant) against closed-form truth."""
import math

import numpy as np
import pytest

from fringe3d.experiments import unwrap_noise


@pytest.fixture(scope="module")
def result(quick_experiment):
    return quick_experiment("unwrap-noise")


def test_no_order_errors_without_noise_for_the_robust_methods(result):
    for m in ("hierarchical 18/144/1024", "heterodyne 18/21/144", "gray code + phase (T/2 stripes)"):
        assert result["rates"][m][0] == 0.0


def test_error_rate_is_non_decreasing_in_noise(result):
    for m, r in result["rates"].items():
        assert all(b >= a for a, b in zip(r, r[1:])), (m, r)
    assert result["rates"]["heterodyne 18/21/144"][-1] > 0.1  # sigma = 32 grey levels really hurts


def test_multi_frequency_rates_match_the_gaussian_tail_prediction(result):
    # measured vs closed-form (N-step phase noise propagated through each level) where the rate is measurable
    for m in ("hierarchical 18/144/1024", "heterodyne 18/21/144"):
        for measured, predicted in zip(result["rates"][m], result["predicted"][m]):
            if predicted > 0.01:
                assert measured == pytest.approx(predicted, rel=0.25), (m, measured, predicted)
            elif predicted < 1e-5:
                assert measured < 1e-3


def test_heterodyne_amplifies_noise_more_than_hierarchical_with_similar_ratios(result):
    h, t = result["rates"]["hierarchical 18/144/1024"], result["rates"]["heterodyne 18/21/144"]
    assert all(b >= a for a, b in zip(h, t))


def test_half_period_gray_code_is_exact_at_every_noise_level_in_the_quick_run(result):
    assert all(r == 0.0 for r in result["rates"]["gray code + phase (T/2 stripes)"])


def test_period_wide_gray_code_takes_the_order_of_the_stripe_edge_it_sits_at():
    """Issue 23: stripe edges at phase 0 of every fringe no longer give the neighbouring order on
    noise-free frames; the fading code bit tells which edge of its stripe a pixel sits at."""
    from fringe3d.decode import DecodeOptions, decode
    from fringe3d.patterns.synthetic import frames_from_coordinates
    ps = unwrap_noise.methods()["gray code + phase (T stripes)"]
    sub, centre = unwrap_noise.phase_field(320, 16)
    frames = frames_from_coordinates(ps, sub, np.full_like(sub, 300.0), unwrap_noise.A, unwrap_noise.B_GAIN)
    opts = DecodeOptions(min_modulation=1.0, edge_mask=False, max_code_residual=math.inf)  # the method's own mask
    d = decode(frames, ps, options=opts)
    assert d.mask["v"].mean() > 0.95
    assert not (np.abs(d.phase["v"] - 2 * np.pi * centre / 18) > np.pi).any()


def test_experiment_command_prints_the_table_as_json(capsys):
    import json

    from fringe3d.cli import main
    assert main(["experiment", "unwrap-noise", "--quick", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["experiment"] == "unwrap-noise" and out["quick"] is True
    assert out["tables"][0]["columns"][:2] == ["sigma", "sigma/B"]
    assert len(out["tables"][0]["rows"]) == len(unwrap_noise.QUICK_SIGMAS)
