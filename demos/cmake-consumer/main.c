/* Links the shared library through sinew.h alone. */
#include <stdio.h>

#include <sinew.h>

int main(void) {
    printf("sinew %s\n", sinew_version());
    return 0;
}
