"""The device: its profile (limits, arithmetic, fixed point) and the cost model fitted to it."""
