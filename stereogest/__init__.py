"""stereogest: stereo-vision hand-gesture recogniser for the DE1-SoC (command-line front end)."""
