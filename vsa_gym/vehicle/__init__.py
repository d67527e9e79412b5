"""Vehicle-level signals shared by the suspension models: ISO 8608 road profiles and ISO 2631-1 comfort."""
