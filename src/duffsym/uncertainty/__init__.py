"""Parameter uncertainty: emcee posterior sampling and identifiability."""
