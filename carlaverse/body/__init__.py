"""Body pose: a walker's joint angles from a camera, as the paper's Pose Process makes them.

    skeleton       what a walk node polls (`SkeletonSource`: poll()/close()), its options
                   (`BodyConfig`) and the Skeleton's joint bytes
    sources        the shipped sources: `camera_source`, `synthetic_source`
    pose_process   camera + landmarker in a process of their own (the `camera` source)
    landmarker     MediaPipe's pose landmarker → 33 world landmarks
    kinematics     landmarks → body frame → shoulder/hip Euler, elbow/knee hinge, neck
    forward        the inverse: landmarks of a person posed by joint angles (tests, synthetic)
    model          the offline, reproducible build of the pose landmarker .task
    tflite_metadata  the input-normalization metadata that build writes into each model
    errors         BodyPoseError and its children

mediapipe and OpenCV are imported only where they are used, so the package imports without
them (the `synthetic` source needs neither).
"""
