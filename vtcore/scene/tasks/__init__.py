"""Task adapters: each module registers one kind of experiment (press, contour, ...)."""
