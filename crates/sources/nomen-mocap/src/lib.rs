//! BVH motion capture parsing and exact forward kinematics into nomen's canonical skeleton.
