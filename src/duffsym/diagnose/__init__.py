"""Where a model fails against measurements and which catalogued effect is missing."""
