"""`rapidc bench nonprehensile`, the eight-task benchmark: the command (run.py) and its table,
the task families and their strategies (tasks/), test scenes, criteria, and the harness and jobs
the verify backends run."""
