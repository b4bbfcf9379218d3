// Compiled only to build cmake/relight_pch.h for its kind of target (cmake/RelightHelpers.cmake).
