"""The application layer: the command line, the demo, playback of a trajectory, and the
waypoint walk that generates one."""
