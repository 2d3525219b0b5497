"""The World: loaded landblocks, movers, and moves answered by the engine."""
