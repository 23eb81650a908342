"""Studies: a study file's participants, conditions and trials, run trial by trial as sessions,
with questionnaires between trials, Lab Streaming Layer signals beside them, and one export."""
