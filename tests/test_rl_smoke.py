"""CI smoke test of the SB3 residual-RL pipeline: a few hundred steps, both variants."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from simgap.control.rl import RL_INFO_KEYWORDS, RLTask, make_rl_env, train_agent  # noqa: E402


def test_rl_env_variants_differ_only_by_the_residual():
    plain, resid = make_rl_env("plain"), make_rl_env("residual")
    assert plain.observation_space.shape == (4,) and resid.observation_space.shape == (6,)
    o1, _ = plain.reset(seed=3)
    o2, _ = resid.reset(seed=3)
    np.testing.assert_array_equal(o1, o2[:4])
    for _ in range(5):
        o1, r1, *_ = plain.step(np.array([0.2], dtype=np.float32))
        o2, r2, _, _, info = resid.step(np.array([0.2], dtype=np.float32))
    np.testing.assert_array_equal(o1, o2[:4])
    assert r1 == r2
    np.testing.assert_allclose(o2[4:], info["residual_estimate"], rtol=1e-6)
    with pytest.raises(ValueError, match="variant"):
        make_rl_env("both")


def test_random_friction_draws_and_fixes_mu():
    env = make_rl_env("plain", RLTask(mu_range=(0.4, 0.7)))
    mus = {env.reset(seed=s)[1]["mu"] for s in range(4)}
    assert len(mus) == 4 and all(0.4 <= m <= 0.7 for m in mus)
    _, info = env.reset(options={"mu": 0.55})
    assert info["mu"] == 0.55 and env.unwrapped.mu == 0.55
    assert env.unwrapped.true_params.mu == 0.55


@pytest.mark.parametrize("variant", ["plain", "residual"])
def test_sac_smoke(variant, tmp_path):
    task = RLTask(episode_seconds=1.0)
    res = train_agent(variant, 0, 250, task=task, log_dir=str(tmp_path), eval_mus=(0.5,))
    assert len(res["episodes"]) == 2  # 100-step episodes
    for row in res["episodes"]:
        for key in RL_INFO_KEYWORDS:
            assert np.isfinite(row[key])
        assert row["residual_true_rms"] > 0
    assert np.isfinite(res["final_return_mean"]) and len(res["base_returns"]) == 1
    assert (tmp_path / f"{variant}_s0.monitor.csv").exists()
