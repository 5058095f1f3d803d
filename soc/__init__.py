"""soc package."""
