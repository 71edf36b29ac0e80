"""extremes."""
