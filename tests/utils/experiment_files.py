"""What the service's experiment tests put in their experiment files."""

TINY_CELL_OVERRIDES = {
    "net.conv_channels": [4, 4],
    "net.latent_dim": 8,
    "net.critic_hidden": 8,
    "net.actor_hidden": 8,
    "agent.batch_size": 8,
    "agent.buffer_size": 500,
    "agent.learning_starts": 10,
    "env.max_steps": 20,
}
"""Per-cell overrides that make a training cell take seconds: tiny networks, small buffer, short episodes."""
