"""Robot arms behind one interface (``interface.RobotBackend``): the real UR5e, simulations, the safety layer.

Nothing is imported here: ``ur_rtde`` and MuJoCo load only when their backend is built.
"""
