"""The closed-loop simulator: world (truth), onboard agents, engine (clock and wiring), recorder."""
