"""Studies of the harness itself, as library modules behind thin scripts in `scripts/`.

`accuracy_time`: what each numerical setting costs and how much accuracy it buys (rods and trials).
`stability_map`: the stable region of modulus x timestep x segments per integrator, and tight coils.
`pull_rate`: whether the pull-out test's peak force and toughness depend on the pull speed.
`profile`: where one trial's time goes; `contact_depth`: how deep contacts go and what load deep ones carry;
`hold_creep`: whether a held grasp sinks, per solver variant, from one saved state (`branching`: run a trial
to a point, save it, continue once per mjOption variant);
`trial_args`: the task/preset/seed/`--set` arguments of one-trial scripts.
All build and simulate through the library: rods through `rods`, trials and probes through `runner`.
"""
