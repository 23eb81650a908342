"""The lab launcher behind `carlaverse launcher`: children, presence, config drafts, hardware
checks (plain Python), and the NiceGUI page over them (`app`, `panel_*`)."""
