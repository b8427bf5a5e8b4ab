"""The eight-task nonprehensile benchmark: task families, test scenes, criteria."""
