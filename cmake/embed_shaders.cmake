file(WRITE ${OUTPUT} "/* placeholder */\n#include <stddef.h>\n")
