"""Expert sources: every demonstrator (scripted, human, teleoperated robot) behind one interface."""
