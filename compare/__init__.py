"""compare: campaigns that run the quasi-static and the dynamic solver on the same scenes."""
