"""Python tools of rbpf_slam: converters of logs and data sets to rosbags, evaluation helpers."""
