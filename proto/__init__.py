"""The aamtrack message contract: msgpack messages and Zenoh key expressions."""
