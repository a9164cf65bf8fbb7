"""The model-free control system (Section 2.1, Fig. 1): the encoder f_ω and decoder, the critic-autoencoder
(Eq. 4, 1), the actor μ and its learners (``learners/``: DDPG (Eq. 2), off-policy CACLA (Eq. 3), TD3 and SAC;
the updates of DDPG, TD3 and SAC are checked against Stable-Baselines3's), replay, the model-free agent, and
RND (``rnd.py``), the intrinsic-motivation peer on any learner.

May import ``core.config`` and ``core.envs``; nothing from ``core.dual``, ``core.runs`` or above.
"""
