"""Where the safe optimiser may look and what it asks for next: given the models, the points to choose from.

Here belongs what turns a posterior into a proposal: the acquisition rules that score candidates
(:mod:`~ksbo_mav.opt.acquisition.rules`), the candidate clouds and their constrained refinement
(:mod:`~ksbo_mav.opt.acquisition.candidates`), the safety certificate that says which points may be queried
(:mod:`~ksbo_mav.opt.acquisition.certificate`) with its exclusion balls around bad trials
(:mod:`~ksbo_mav.opt.acquisition.exclusion`), the search region and trust region that bound the search
(:mod:`~ksbo_mav.opt.acquisition.region`, :mod:`~ksbo_mav.opt.acquisition.trust_region`), and LineBO's proposer
on one line (:mod:`~ksbo_mav.opt.acquisition.lines`). A module here never fits a GP (``opt.models``) and never
calls the objective (``opt.methods``).
"""
