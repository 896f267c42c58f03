"""The field: each UAV's stack fed by its own sensor and autopilot, its neighbours heard over the real network, no
world in between (``swarmtrack agent --field``); a monitor that records what the agents publish; and a stand-in
that runs it all on one machine with nothing a real deployment lacks (docs/field.md)."""
