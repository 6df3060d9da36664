"""Camera response functions: forward, inverse, derivative, certainty/weighting and frame variance."""
