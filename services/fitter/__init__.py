"""The fitter service: AAM fitting on video frames, with the warp on the GPU where one can run."""
