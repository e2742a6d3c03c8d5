"""The material-point driver: stress and strain paths through one model."""
