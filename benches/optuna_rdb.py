"""Optuna with RDB storage on a PostgreSQL server: the reference row of
`cargo bench --features postgres --bench distributed` (docs/BENCHMARKS.md).

    python benches/optuna_rdb.py URL SIMULATOR TRIALS THREADS

URL: postgresql+psycopg2://user:password@host:port/db; SIMULATOR: null (returns at once) or
sleep (every call sleeps 20 ms); THREADS: `n_jobs` of `study.optimize` (threads of one process,
each trial its own storage transactions). RandomSampler over one float (the sampler costs
nothing: this measures the storage and the objective calls). Prints `seconds trials`.
"""

import sys
import time

import optuna


def main():
    url, sim, trials, threads = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = optuna.storages.RDBStorage(url, engine_kwargs={"pool_size": threads + 2})
    name = f"bench-{sim}-{threads}-{time.time_ns()}"
    study = optuna.create_study(
        study_name=name, storage=storage, sampler=optuna.samplers.RandomSampler(seed=1)
    )

    def objective(trial):
        x = trial.suggest_float("x", 0.0, 1.0)
        if sim == "sleep":
            time.sleep(0.02)
        return x

    start = time.perf_counter()
    study.optimize(objective, n_trials=trials, n_jobs=threads)
    seconds = time.perf_counter() - start
    done = len(study.get_trials(deepcopy=False))
    print(f"{seconds:.4f} {done}")


if __name__ == "__main__":
    main()
