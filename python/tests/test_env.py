"""hevo.Env and hevo.VectorEnv: a task as an environment with Gymnasium's conventions, on the
evaluator's own control loop. An episode driven with a shipped controller's outputs reproduces
`hevo.trace` cycle by cycle and `hevo.evaluate`'s outcome exactly; episodes are deterministic
per seed; the vector form is the single one, environment by environment."""

import numpy as np
import pytest

import hevo


@pytest.fixture(scope="module")
def maze(repo):
    return hevo.Controller.load(repo / "controllers" / "solve_maze.json")


def drive(env, inputs, outputs):
    """Steps `env` (just reset) with `outputs`, checking each observation against `inputs`;
    the last step's (reward, terminated, truncated, info) and the steps taken."""
    for cycle, action in enumerate(outputs):
        obs, reward, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return reward, terminated, truncated, info, cycle + 1
        np.testing.assert_array_equal(obs, inputs[cycle + 1], err_msg=f"cycle {cycle + 1}")
        assert reward == 0.0 and info == {}
    raise AssertionError(f"no end after the trace's {len(outputs)} cycles")


def test_the_shipped_controllers_outputs_reproduce_trace_and_evaluate(maze):
    task = hevo.Task("solve_maze")
    result = hevo.evaluate(
        maze.without_genome("solve_maze"), maze.genome("solve_maze")[None, :], task,
        samples=2, seed=5, threads=1,
    )
    env = hevo.Env(task)
    for j, sample_seed in enumerate(result.sample_seeds):
        variant = int(result.sample_variant[0, j])
        trace = hevo.trace(maze, task, seed=int(sample_seed), variant=variant)
        obs, info = env.reset(options={"sample_seed": int(sample_seed), "variant": variant})
        assert info == {"sample_seed": int(sample_seed), "variant": variant}
        assert obs.dtype == np.float32 and obs.shape == (17,)
        np.testing.assert_array_equal(obs, trace.inputs[0])
        reward, terminated, truncated, info, steps = drive(env, trace.inputs, trace.outputs)
        outcome = trace.outcome
        assert steps == len(trace) == info["cycles"] == result.sample_cycles[0, j]
        # Exactly the evaluation's fitness: the float32 fitness, as a Python float.
        assert reward == info["fitness"] == result.sample_fitness[0, j]
        assert np.float32(reward) == np.float32(outcome["fitness"])
        assert info["ending"] == outcome["ending"]
        assert info["solved"] == outcome["solved"] == result.sample_solved[0, j]
        assert info["collided"] == result.sample_collided[0, j]
        assert info["stage"] == result.sample_stage[0, j]
        assert info["variant"] == variant
        assert info["sample_seed"] == sample_seed
        assert truncated == (outcome["ending"] == "timeout")
        assert terminated == (not truncated)
        assert not env.running


def linear_policy(weights):
    return lambda obs: 1 / (1 + np.exp(-(obs @ weights)))


def rollout(env, policy, steps):
    """Observations, rewards and ends of `steps` steps of a single env (reset at each end)."""
    obs, info = env.reset()
    record = [obs, info["sample_seed"]]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        record += [obs, reward, terminated, truncated]
        if terminated or truncated:
            obs, info = env.reset()
            record += [obs, info["sample_seed"]]
    return record


def test_episodes_are_deterministic_per_seed():
    task = hevo.Task("follow_wall", max_cycles=40)
    policy = linear_policy(np.random.default_rng(0).normal(0, 2, (17, 2)))
    first = rollout(hevo.Env(task, seed=11), policy, 130)
    again = rollout(hevo.Env(task, seed=11), policy, 130)
    other = rollout(hevo.Env(task, seed=12), policy, 130)
    same = lambda a, b: all(np.array_equal(x, y) for x, y in zip(a, b))
    assert len(first) == len(again) and same(first, again)
    assert not same(first, other)
    # reset(seed=s) restarts the episodes of s; reset() goes on to the next one.
    env = hevo.Env(task, seed=3)
    start, info = env.reset(seed=11)
    np.testing.assert_array_equal(start, first[0])
    assert info["sample_seed"] == first[1]
    _, next_info = env.reset()
    assert next_info["sample_seed"] != info["sample_seed"]
    _, info = env.reset(seed=11)
    assert info["sample_seed"] == first[1]


def test_a_vector_env_is_its_single_envs_with_next_step_autoreset():
    task = hevo.Task("solve_maze", max_cycles=30)
    n_envs, seed = 3, 21
    vector = hevo.VectorEnv(task, n_envs, seed=seed)
    singles = [hevo.Env(task, seed=seed + i) for i in range(n_envs)]
    weights = np.random.default_rng(1).normal(0, 2, (17, 2))
    obs, info = vector.reset()
    assert obs.shape == (n_envs, 17) and obs.dtype == np.float32
    assert info["_sample_seed"].all()
    single_obs = []
    for i, env in enumerate(singles):
        first, single_info = env.reset()
        single_obs.append(first)
        assert info["sample_seed"][i] == single_info["sample_seed"]
        assert info["variant"][i] == single_info["variant"]
    np.testing.assert_array_equal(obs, np.stack(single_obs))
    ended_seen = resets_seen = 0
    pending_reset = np.zeros(n_envs, bool)
    for step in range(70):
        actions = 1 / (1 + np.exp(-(obs.astype(np.float64) @ weights)))
        obs, rewards, terminated, truncated, info = vector.step(actions)
        assert rewards.dtype == np.float64 and terminated.dtype == np.bool_
        for i, env in enumerate(singles):
            if pending_reset[i]:
                # Next-step autoreset: the action is ignored, the new episode's first frame.
                first, single_info = env.reset()
                np.testing.assert_array_equal(obs[i], first)
                assert rewards[i] == 0 and not terminated[i] and not truncated[i]
                assert info["_sample_seed"][i] and info["sample_seed"][i] == single_info["sample_seed"]
                resets_seen += 1
                continue
            single = env.step(actions[i])
            np.testing.assert_array_equal(obs[i], single[0], err_msg=f"step {step}, env {i}")
            assert (rewards[i], terminated[i], truncated[i]) == single[1:4]
            if terminated[i] or truncated[i]:
                assert info["_fitness"][i] and info["fitness"][i] == np.float32(single[1])
                for key in ("solved", "collided", "stage", "variant", "cycles", "sample_seed"):
                    assert info[key][i] == single[4][key], key
                assert info["ending"][i] == single[4]["ending"]
                ended_seen += 1
            elif info:
                assert not info["_sample_seed"][i]
        pending_reset = terminated | truncated
    assert ended_seen >= n_envs and resets_seen >= n_envs


def test_actions_any_float_dtype_clipped_nan_refused():
    task = hevo.Task("follow_wall", max_cycles=30, end_on_collision=False)

    def run(action):
        env = hevo.Env(task, seed=2)
        env.reset()
        observations = []
        while True:
            obs, reward, terminated, truncated, _ = env.step(action)
            observations.append(obs)
            if terminated or truncated:
                return np.stack(observations), reward
    reference = run(np.array([1.0, 0.25], np.float32))
    for action in ([1.0, 0.25], np.array([1.0, 0.25]), np.array([1.0, 0.25], np.float16),
                   np.array([3.0, 0.25]), (1.5, 0.25)):
        observations, reward = run(action)
        np.testing.assert_array_equal(observations, reference[0])
        assert reward == reference[1]
    assert reference[0].any(), "the robot senses a wall"
    still = run([0.5, 0.5])
    assert not np.array_equal(still[0], reference[0]), "the wheels move the robot"
    assert still[1] != reference[1]

    env = hevo.Env(task, seed=2)
    with pytest.raises(hevo.RunError, match="call reset"):
        env.step([0.5, 0.5])
    env.reset()
    with pytest.raises(ValueError, match=r"action\[1\] \(right wheel\) is NaN"):
        env.step([0.5, float("nan")])
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        env.step([0.5, 0.5, 0.5])
    with pytest.raises(TypeError, match="float array"):
        env.step(np.array([1, 0]))
    for _ in range(30):
        env.step([0.5, 0.5])
    with pytest.raises(hevo.RunError, match="call reset"):
        env.step([0.5, 0.5])

    vector = hevo.VectorEnv(task, 2, seed=2)
    with pytest.raises(hevo.RunError, match="call reset"):
        vector.step(np.full((2, 2), 0.5))
    vector.reset()
    with pytest.raises(ValueError, match=r"actions\[1\]\[0\] \(left wheel\) is inf"):
        vector.step(np.array([[0.5, 0.5], [np.inf, 0.5]]))
    with pytest.raises(ValueError, match=r"shape \(2, 2\)"):
        vector.step(np.full((3, 2), 0.5))


def test_options_seeds_and_spaces():
    task = hevo.Task("solve_maze")
    env = hevo.Env(task, seed=0)
    assert env.observation_names == hevo.trace(
        hevo.bench_controller(task), task, seed=0).input_names
    assert env.observation_space.shape == (17,) and env.action_space.shape == (2,)
    np.testing.assert_array_equal(env.observation_space.low, np.zeros(17, np.float32))
    np.testing.assert_array_equal(env.action_space.high, np.ones(2, np.float32))
    assert env.action_space.dtype == "float32"
    assert repr(env.action_space) == "Space(shape=(2,), low=0, high=1, dtype=float32)"
    assert env.max_episode_steps == task.max_cycles
    _, info = env.reset(options={"variant": 3})
    assert info["variant"] == 3
    with pytest.raises(hevo.ConfigError, match="variant 4 is out of range"):
        env.reset(options={"variant": 4})
    with pytest.raises(hevo.ConfigError, match="unknown option 'seed'"):
        env.reset(options={"seed": 1})
    vector = hevo.VectorEnv(task, 4, seed=7)
    assert len(vector) == vector.num_envs == 4
    assert vector.observation_space.shape == (4, 17)
    assert vector.single_action_space.shape == (2,)
    _, by_int = vector.reset(seed=7)
    _, by_list = vector.reset(seed=[7, 8, 9, 10])
    np.testing.assert_array_equal(by_int["sample_seed"], by_list["sample_seed"])
    with pytest.raises(ValueError, match="one per environment"):
        vector.reset(seed=[1, 2])
    with pytest.raises(hevo.ConfigError, match="takes no options"):
        vector.reset(options={"variant": 1})
    with pytest.raises(ValueError, match="n_envs is 0"):
        hevo.VectorEnv(task, 0)
