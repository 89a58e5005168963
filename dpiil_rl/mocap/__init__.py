"""Motion capture: where the person's hand is (UR5e teleoperation path).

A :class:`~dpiil_rl.mocap.base.MocapSource` streams rigid-body poses: live from OptiTrack Motive over
NatNet (:mod:`dpiil_rl.mocap.natnet`), or from a recorded hand trajectory (:mod:`dpiil_rl.mocap.replay`)
so the teleoperation path runs, and is tested, without a capture volume.
"""
