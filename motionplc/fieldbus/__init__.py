"""motionplc.fieldbus — see the project issues; filled in by later work."""
