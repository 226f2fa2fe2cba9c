"""The workbench nodes: recorder, player, monitor, Foxglove bridge."""
