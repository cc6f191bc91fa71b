"""Hard cases: scenes at the edges of what the stone, the water and their coupling must survive."""
