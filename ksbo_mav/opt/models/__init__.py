"""What the safe optimiser believes about the objective: the models fitted to the trials.

Here belongs everything that is fitted to the data and predicts at new gains: the GP on the safety margin and the
options that shape it (:mod:`~ksbo_mav.opt.models.safety_model`), the surrogate that holds the main, safety and
acquisition GPs (:mod:`~ksbo_mav.opt.models.surrogate`), the learned safety lengthscales
(:mod:`~ksbo_mav.opt.models.scale`), the chance a trial aborts or crashes
(:mod:`~ksbo_mav.opt.models.failure_model`) and ksbo's choice of the additive kernel
(:mod:`~ksbo_mav.opt.models.selection`). A module here reads trials and answers with a posterior; it never decides
which point to fly next (``opt.acquisition``) nor runs a loop (``opt.methods``).
"""
