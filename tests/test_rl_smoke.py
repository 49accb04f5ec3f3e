"""CI smoke test of the SB3 residual-RL pipeline: a few hundred steps, both variants."""

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import simgap  # noqa: E402, F401  (registers the env ids)
from simgap.control.rl import (  # noqa: E402
    RL_INFO_KEYWORDS,
    RL_TASK_ID,
    RLTask,
    make_rl_env,
    mean_ci95,
    train_agent,
)
from tests.conftest import REPO_ROOT  # noqa: E402


def test_rl_env_variants_differ_only_by_the_residual():
    plain, resid = make_rl_env("plain"), make_rl_env("residual")
    assert plain.observation_space.shape == (4,) and resid.observation_space.shape == (6,)
    assert np.all(resid.observation_space.high[4:] == 10.0)  # scaled ĝ, clipped
    o1, _ = plain.reset(seed=3)
    o2, _ = resid.reset(seed=3)
    np.testing.assert_array_equal(o1, o2[:4])
    for _ in range(60):  # baseline 2 (the task's identifier) updates every 10 steps
        o1, r1, *_ = plain.step(np.array([0.2], dtype=np.float32))
        o2, r2, _, _, info = resid.step(np.array([0.2], dtype=np.float32))
    np.testing.assert_array_equal(o1, o2[:4])
    assert r1 == r2
    scale = info["residual_observation_scale"]
    assert np.all(scale > 0)
    np.testing.assert_allclose(o2[4:], info["residual_estimate"] / scale, rtol=1e-5)
    with pytest.raises(ValueError, match="variant"):
        make_rl_env("both")
    with pytest.raises(ValueError, match="not both"):
        make_rl_env("plain", RLTask(), vx=10.0)


def test_registered_task_observes_the_reference_and_takes_normalised_actions():
    env = gym.make(RL_TASK_ID, variant="residual", mu_range=(0.5, 0.6))
    assert env.action_space.low[0] == -1.0 and env.action_space.high[0] == 1.0
    obs, info = env.reset(seed=1)
    base = env.unwrapped
    ref = base.reference
    t = 0.0
    for a in (1.0, -1.0, 5.0):
        obs, _, _, _, info = env.step(np.array([a], dtype=np.float32))
        t = info["t"]
        # the reference for the next step is in the observation, not only in info
        np.testing.assert_allclose(obs[2], ref(t + base.dt), rtol=1e-6)
        applied = info["applied_action"][0]
        expected = np.clip(info["base_steering"] + 0.05 * np.clip(a, -1, 1), -0.5, 0.5)
        np.testing.assert_allclose(applied, expected, rtol=1e-9)
    assert 0.5 <= info["mu"] <= 0.6


def test_mean_ci95_matches_the_t_interval():
    m, h = mean_ci95(np.array([[1.0, 2.0], [3.0, np.nan], [5.0, 4.0]]))
    np.testing.assert_allclose(m, [3.0, 3.0])
    np.testing.assert_allclose(h[0], 4.302652729749464 * 2.0 / np.sqrt(3), rtol=1e-9)
    assert h[1] == pytest.approx(12.706204736174705 * np.sqrt(2.0) / np.sqrt(2))


@pytest.mark.parametrize("variant", ["plain", "residual"])
def test_sac_smoke(variant, tmp_path):
    task = RLTask(episode_seconds=1.0)
    res = train_agent(variant, 0, 250, task=task, log_dir=str(tmp_path), eval_mus=(0.5,),
                      eval_every=100)
    assert len(res["episodes"]) == 2  # 100-step episodes
    for row in res["episodes"]:
        for key in RL_INFO_KEYWORDS:
            assert np.isfinite(row[key])
        assert row["residual_true_rms"] > 0
    assert [e["step"] for e in res["evals"]] == [0, 100, 200, 250]
    assert np.isfinite(res["final_return_mean"]) and len(res["base_returns"]) == 1
    assert (tmp_path / f"{variant}_s0.monitor.csv").exists()


def test_rl_benchmark_quick_variant(tmp_path):
    """The CI variant of benchmarks/rl_residual.py: JSON, summary and figure."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "rl_residual", REPO_ROOT / "benchmarks" / "rl_residual.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    res = mod.main(["--quick", "--out", str(tmp_path)])
    data = json.loads((tmp_path / "rl_residual_quick.json").read_text())
    assert data["complete"] and len(data["runs"]) == 2
    assert data["summary"]["plain"]["seeds"] == [0] == res["summary"]["residual"]["seeds"]
    assert (tmp_path / "rl_residual_quick.png").stat().st_size > 10_000
    # a second "process" with seed 1 (and an unfinished seed 2), merged into one result
    other = json.loads(json.dumps(data))
    for run in other["runs"]:
        run["seed"] = 1
    other["runs"].append({**other["runs"][0], "seed": 2})
    other["settings"]["seeds"] = [1, 2]
    (tmp_path / "b.json").write_text(json.dumps(other))
    merged = mod.main(["--merge", str(tmp_path / "rl_residual_quick.json"),
                       str(tmp_path / "b.json"), "--out", str(tmp_path), "--name", "m"])
    assert merged["settings"]["seeds"] == [0, 1] and len(merged["runs"]) == 4
    assert merged["summary"]["plain"]["seeds"] == [0, 1]
    assert merged["completed_seeds"] == [0, 1] and merged["seeds_pending"] == [2]
    assert (tmp_path / "m.png").exists()
    # an extra residual-only variant with a declared ĝ scale, compared with the main result
    fixed = mod.main(["--quick", "--out", str(tmp_path), "--name", "fx", "--variants",
                      "residual", "--residual-scale", "1.0", "0.5", "--against",
                      str(tmp_path / "rl_residual_quick.json")])
    assert [r["variant"] for r in fixed["runs"]] == ["residual"]
    assert fixed["completed_seeds"] == [0] and fixed["seeds_pending"] == []
    assert fixed["settings"]["task"]["residual_scale"] == [1.0, 0.5]
    assert fixed["summary"]["against"]["seeds"] == [0] and "plain" not in fixed["summary"]
    assert (tmp_path / "fx.png").stat().st_size > 10_000
