"""Test-only helpers (dat writer, scene comparison, shared data paths); never imported by the project."""
