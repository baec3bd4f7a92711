"""SPH building blocks: smoothing kernels, neighbour lists, corrected operators."""
