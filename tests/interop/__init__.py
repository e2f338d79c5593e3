"""Interoperability peers written from the standards, independent of ``motionplc.fieldbus``."""
