#pragma once
// Core OpenGL entry points, linked directly from GLVND's libOpenGL (no loader):
// DESIGN.md, "Dependencies".
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
