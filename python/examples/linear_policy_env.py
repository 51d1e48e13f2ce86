"""A numpy linear policy trained on `hevo.VectorEnv` by an evolution strategy: a policy hevo
knows nothing about, driving the robot step by step from its sensor frame.

The policy maps the sensor frame (`env.observation_names`: 17 inputs, IR, light, near-robot,
range and bearing, items) to the two wheel outputs, `sigmoid(obs @ W + b)` (36 parameters). Each iteration perturbs it in `population` antithetic directions, runs every
perturbed policy on the same `episodes` samples (one environment per policy and sample, all
stepped together in Rust), and moves along the directions weighted by their rank, as in
Salimans et al.'s evolution strategies. Then the policy is scored on samples it never saw.

    python python/examples/linear_policy_env.py --task exit_room --iterations 40
"""

import argparse
import time

import numpy as np

import hevo


def act(params, obs):
    """Wheel outputs for each environment: params (n_envs, n_obs + 1, 2), obs (n_envs, n_obs)."""
    x = np.concatenate([obs, np.ones((len(obs), 1), obs.dtype)], axis=1)
    return 1.0 / (1.0 + np.exp(-np.einsum("ni,nio->no", x, params)))


def episode_returns(task, params, seeds):
    """Each environment's return for one episode: environment i runs the policy params[i] on
    the first sample of seed seeds[i]."""
    env = hevo.VectorEnv(task, len(params), seed=0)
    obs, _ = env.reset(seed=[int(seed) for seed in seeds])
    returns = np.zeros(len(params))
    done = np.zeros(len(params), bool)
    while not done.all():
        obs, rewards, terminated, truncated, _ = env.step(act(params, obs))
        # Environments that ended go on with a new episode (autoreset); only the first counts.
        returns += np.where(done, 0.0, rewards)
        done |= terminated | truncated
    return returns


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="exit_room")
    parser.add_argument("--iterations", type=int, default=40)
    parser.add_argument("--population", type=int, default=16, help="perturbations (even)")
    parser.add_argument("--episodes", type=int, default=4, help="samples per policy")
    parser.add_argument("--max-cycles", type=int, default=None, help="override the task's")
    parser.add_argument("--sigma", type=float, default=0.5)
    parser.add_argument("--step", type=float, default=0.3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    overrides = {} if args.max_cycles is None else {"max_cycles": args.max_cycles}
    task = hevo.Task(args.task, **overrides)
    rng = np.random.default_rng(args.seed)
    # One weight row per observation column and one for the bias.
    n_weights = len(hevo.Env(task, seed=0).observation_names) + 1
    policy = np.zeros((n_weights, 2))
    half = args.population // 2
    started = time.perf_counter()
    for iteration in range(args.iterations):
        noise = rng.normal(size=(half, n_weights, 2))
        candidates = np.concatenate([policy + args.sigma * noise, policy - args.sigma * noise])
        # Every candidate on the same samples: environment (candidate c, episode e) is seeded
        # with the iteration's e-th seed.
        episode_seeds = rng.integers(0, 2**63, size=args.episodes)
        params = np.repeat(candidates, args.episodes, axis=0)
        seeds = np.tile(episode_seeds, len(candidates))
        returns = episode_returns(task, params, seeds).reshape(len(candidates), args.episodes)
        scores = returns.mean(axis=1)
        ranks = scores.argsort().argsort() / (len(scores) - 1) - 0.5
        direction = np.einsum("k,kij->ij", ranks[:half] - ranks[half:], noise)
        policy += args.step / (half * args.sigma) * direction
        print(f"iteration {iteration + 1:3d}: mean fitness {scores.mean():.4f}, "
              f"best {scores.max():.4f}")
    test_seeds = np.arange(1_000_000, 1_000_000 + 50)
    final = episode_returns(task, np.repeat(policy[None], len(test_seeds), axis=0), test_seeds)
    print(f"the policy on 50 new samples of {task.name}: mean fitness {final.mean():.4f}")
    print(f"{time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
