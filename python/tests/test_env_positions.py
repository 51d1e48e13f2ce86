"""hevo.Env's positions: after every reset and step, info says where a team's other robots,
the movers, the boxes and the items are. Each shipped swarm scenario runs here with its
`evolved` robots made wanderers (an environment drives the focal robot alone and refuses
evolved copies); an episode driven with a controller's traced outputs must show, cycle by
cycle, what the trace of the same sample recorded (`trace.poses`, and the `mover[i]_x`,
`box[i]_x`, `item[i]_x`, ... columns of `trace.to_json()`), and at the end where everything
ended. `VectorEnv`'s positions are its single environments', lane by lane. A scenario
without such bodies has none of the keys."""

import json

import numpy as np
import pytest

import hevo

POSITION_KEYS = {
    "team_poses",
    "mover_positions",
    "box_positions",
    "item_positions",
    "item_carried",
    "item_delivered",
}


def wandering(repo, tmp_path, name):
    """The shipped scenario `scenarios/swarm/NAME.toml` with its evolved robots wandering."""
    text = (repo / "scenarios" / "swarm" / f"{name}.toml").read_text()
    assert 'controller = "evolved"' in text
    path = tmp_path / f"{name}.toml"
    path.write_text(text.replace('controller = "evolved"', 'controller = "wander"'))
    return hevo.Task(path)


def episode_beside_trace(repo, task, controller_name, seed=3):
    """Drives an `Env` with the traced outputs of the shipped controller `controller_name` on
    sample `seed`: every info (the reset's, then each step's), the trace and its JSON."""
    controller = hevo.Controller.load(repo / "controllers" / f"{controller_name}.json")
    trace = hevo.trace(controller, task, seed=seed)
    env = hevo.Env(task)
    _, info = env.reset(options={"sample_seed": seed, "variant": trace.variant})
    infos = [info]
    for action in trace.outputs:
        _, _, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            break
    assert len(infos) == len(trace) + 1
    return infos, trace, json.loads(trace.to_json())


def as_f32(values):
    return np.asarray(values, dtype=np.float32)


def recorded(document, cycle, kind, count, suffixes=("_x", "_y")):
    """The trace table's columns `KIND[i]SUFFIX` of one cycle, a row per body."""
    row = document["cycles"][cycle]
    return [[row[f"{kind}[{idx}]{suffix}"] for suffix in suffixes] for idx in range(count)]


def test_info_has_the_teams_poses_every_cycle(repo, tmp_path):
    task = wandering(repo, tmp_path, "crossing")
    infos, trace, _ = episode_beside_trace(repo, task, "crossing")
    # trace.robots: the robot, then the team's other robots.
    assert trace.robots[0] == "robot" and len(trace.robots) == 3
    for cycle, info in enumerate(infos[:-1]):
        poses = info["team_poses"]
        assert poses.dtype == np.float64 and poses.shape == (2, 3)
        np.testing.assert_array_equal(as_f32(poses), trace.poses[cycle, 1:], f"cycle {cycle}")
    assert infos[-1]["team_poses"].shape == (2, 3)


def test_info_has_the_movers_positions_every_cycle(repo, tmp_path):
    task = wandering(repo, tmp_path, "crossing")
    infos, _, document = episode_beside_trace(repo, task, "crossing")
    for cycle, info in enumerate(infos[:-1]):
        movers = info["mover_positions"]
        assert movers.dtype == np.float64 and movers.shape == (3, 2)
        np.testing.assert_array_equal(movers, recorded(document, cycle, "mover", 3))
        assert "box_positions" not in info and "item_positions" not in info
    assert infos[-1]["mover_positions"].shape == (3, 2)
    # They patrol: the first cycle's centres are not the last's.
    assert not np.array_equal(infos[0]["mover_positions"], infos[-1]["mover_positions"])


def test_info_has_the_boxes_positions_every_cycle(repo, tmp_path):
    task = wandering(repo, tmp_path, "box_pushing")
    infos, _, document = episode_beside_trace(repo, task, "follow_wall")
    for cycle, info in enumerate(infos[:-1]):
        boxes = info["box_positions"]
        assert boxes.dtype == np.float64 and boxes.shape == (4, 2)
        np.testing.assert_array_equal(boxes, recorded(document, cycle, "box", 4))
        assert "mover_positions" not in info
    assert infos[-1]["box_positions"].shape == (4, 2)


def test_info_has_the_items_positions_and_states_every_cycle(repo, tmp_path):
    task = wandering(repo, tmp_path, "foraging")
    infos, trace, document = episode_beside_trace(repo, task, "foraging")
    for cycle, info in enumerate(infos[:-1]):
        assert info["item_positions"].dtype == np.float64
        assert info["item_positions"].shape == (10, 2)
        np.testing.assert_array_equal(
            info["item_positions"], recorded(document, cycle, "item", 10)
        )
        states = [state for [state] in recorded(document, cycle, "item", 10, ("_state",))]
        assert info["item_carried"].tolist() == [state == "carried" for state in states]
        assert info["item_delivered"].tolist() == [state == "delivered" for state in states]
        # A carried item is on the robot or one of the wanderers.
        robots = trace.poses[cycle, :, :2]
        for at in as_f32(info["item_positions"])[info["item_carried"]]:
            assert (robots == at).all(axis=1).any(), (cycle, at)
    # An item once delivered stays delivered, to the end.
    delivered = np.array([info["item_delivered"] for info in infos])
    assert (np.diff(delivered.astype(int), axis=0) >= 0).all()
    # The shipped forager picks an item up in this sample: the states are not all "floor".
    assert any(info["item_carried"].any() for info in infos)


@pytest.mark.parametrize("name", ["follow_wall", "exit_room"])
def test_info_has_no_positions_without_such_bodies(name):
    env = hevo.Env(hevo.Task(name), seed=1)
    _, info = env.reset()
    assert POSITION_KEYS.isdisjoint(info)
    _, _, _, _, info = env.step([0.5, 0.5])
    assert info == {}


def test_a_vector_envs_positions_are_its_single_envs(repo, tmp_path):
    task = wandering(repo, tmp_path, "foraging")
    vector = hevo.VectorEnv(task, 2, seed=5)
    singles = [hevo.Env(task, seed=5 + i) for i in range(2)]
    keys = ["team_poses", "item_positions", "item_carried", "item_delivered"]
    _, info = vector.reset()
    single_infos = [env.reset()[1] for env in singles]
    rng = np.random.default_rng(1)
    for step in range(40):
        for key in keys:
            assert info[f"_{key}"].all(), key
            assert info[key].shape[0] == 2
            for i, single in enumerate(single_infos):
                np.testing.assert_array_equal(info[key][i], single[key], f"{key}, step {step}")
        assert "mover_positions" not in info
        actions = rng.uniform(0, 1, (2, 2))
        _, _, terminated, truncated, info = vector.step(actions)
        single_infos = [env.step(action)[4] for env, action in zip(singles, actions)]
        assert not (terminated.any() or truncated.any())
    # The team moved: the positions are the cycle's, not the start's again.
    assert not np.array_equal(info["team_poses"], vector.reset(seed=5)[1]["team_poses"])
