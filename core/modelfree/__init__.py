"""The model-free control system (Section 2.1, Fig. 1): the encoder f_ω and decoder, the critic-autoencoder
(Eq. 4, 1), the actor μ with DDPG (Eq. 2) or off-policy CACLA (Eq. 3) updates, replay, the model-free agent.

May import ``core.config`` and ``core.envs``; nothing from ``core.dual``, ``core.runs`` or above.
"""
