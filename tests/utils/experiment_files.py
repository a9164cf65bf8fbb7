"""What the service's experiment tests put in their experiment files."""

TINY_NETS = {
    "net.conv_channels": [4, 4],
    "net.latent_dim": 8,
    "net.critic_hidden": 8,
    "net.actor_hidden": 8,
}
"""The smallest networks a pixel run trains with: a test's runs cost seconds."""

TINY_CELL_OVERRIDES = {
    **TINY_NETS,
    "agent.batch_size": 8,
    "agent.buffer_size": 500,
    "agent.learning_starts": 10,
    "env.max_steps": 20,
}
"""Per-cell overrides that make a training cell take seconds: tiny networks, small buffer, short episodes."""
