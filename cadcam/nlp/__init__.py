"""The design NLP: transcription of a problem for IPOPT."""
