"""`python -m platoon ...`: the `platoon` command."""

from platoon._cli import main

main()
