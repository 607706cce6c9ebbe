"""Bringup of the impurity-picking cell: the node graph and its parameter files (cell_nodes), the pip
launcher (launch_cell), the episode client (episode_client), `make demo` (demo) and the graph evaluation
(eval_graph). Installed with share/impurity_bringup/launch/cell.launch.py and config/*.yaml."""
