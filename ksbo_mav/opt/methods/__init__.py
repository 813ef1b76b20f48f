"""The optimisers themselves: loops that spend a :class:`~ksbo_mav.opt.problem.Problem`'s budget.

Here belongs what runs a method end to end and decides its answer: the safe BO state machine
(:mod:`~ksbo_mav.opt.methods.safe_bo`) and its builder from the options
(:mod:`~ksbo_mav.opt.methods.build`), the driver loop (:mod:`~ksbo_mav.opt.methods.loop`), the run's phases
(:mod:`~ksbo_mav.opt.methods.phases`), the re-fly phase and the recommendation
(:mod:`~ksbo_mav.opt.methods.refly`, :mod:`~ksbo_mav.opt.methods.recommend`), the safe methods that differ in
their kernel (:mod:`~ksbo_mav.opt.methods.safe_methods`), safe LineBO (:mod:`~ksbo_mav.opt.methods.linebo`) and
the unconstrained baselines (:mod:`~ksbo_mav.opt.methods.unconstrained`). :func:`ksbo_mav.opt.run_method` picks
one by name. A method composes ``opt.models`` and ``opt.acquisition``; only a method asks the problem for
evaluations.
"""
