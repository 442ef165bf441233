"""The design NLP: transcription of a problem for IPOPT, and its compiled-function cache."""
