"""The nonlinear program of a problem (`transcription`): the terms of every step (`terms`)
in a separable NLP (`separable`), assembled by the index arithmetic of `gather_scatter`,
with the momentum treatment (`momenta`), the scales (`scaling`) and its evaluation at a
point (`evaluation`)."""
