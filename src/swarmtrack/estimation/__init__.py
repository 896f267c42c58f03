"""Estimators: information-form EKF (reference, numpy), compiled CV kernels, covariance-form EKF."""
