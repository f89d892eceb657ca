"""The closed loop's set-ups built from model files: predictors, their C and boards for seagen.control."""
