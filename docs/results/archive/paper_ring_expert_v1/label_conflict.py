"""Label conflicts of the ring expert per run (run with the package installed: python label_conflict.py <run dirs>)."""
import sys, torch
from dpiil_rl.study.expert_pairs import load_dataset
from dpiil_rl.envs.ring_task import RingState, handle_position, RingGeometry
g = RingGeometry()
for run in sys.argv[1:]:
    d = load_dataset(run, 200000)
    s = RingState(d['observation']); h = handle_position(s, g)
    xy = (s.eef_pos[:, :2] - h[:, :2]).norm(dim=-1); dz = s.eef_pos[:, 2] - h[:, 2]
    open_ = s.gripper_qpos[:, 0] < 0.1
    a = d['expert_action']; it = d['iteration']
    for part, m0 in (('k=0', it == 0), ('k>=1', it >= 1)):
        m = m0 & open_ & (xy < 0.015) & (dz > 0.02) & (dz < 0.05)
        az = a[m, 2]
        print(run.split('ring/')[1], part, 'pairs over handle dz 2-5cm open:', int(m.sum()), ' up(az>0.05): %.2f down(az<-0.05): %.2f' % ((az > 0.05).float().mean(), (az < -0.05).float().mean()))
