import pickle

from dpiil_rl.utils.sweep_progress import SweepProgress, count_jobs


def test_count_jobs_is_the_product_of_sweeps():
    assert count_jobs(["env=ring", "method=bc,dagger,dpiil_ucb", "seed=0,1,2", "logger=csv"]) == 9
    assert count_jobs(["method=dpiil_ucb", "chi=1e-5,1e-4", "seed=range(0,4)"]) == 8
    assert count_jobs(["seed=0"]) == 1


def test_callback_travels_to_workers_without_its_bar():
    cb = pickle.loads(pickle.dumps(SweepProgress(poll_s=0.5)))
    assert cb.poll_s == 0.5 and cb._bar is None
