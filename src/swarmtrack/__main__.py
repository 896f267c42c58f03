"""``python -m swarmtrack``: the command line (what ``swarmtrack live`` starts its UAV processes with)."""

from swarmtrack.cli import main

main(prog_name="swarmtrack")
